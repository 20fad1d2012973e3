#include "thermovis/camera/rectified.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace thermovis::camera {

RectifiedIntrinsics scaled(const RectifiedIntrinsics& grid, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw std::invalid_argument("rectified grid: scale must be positive and finite");
  }
  RectifiedIntrinsics out = grid;
  out.width = 2 * static_cast<int>(std::ceil(grid.width * scale / 2.0));
  out.height = 2 * static_cast<int>(std::ceil(grid.height * scale / 2.0));
  out.f = grid.f * scale;
  out.cx = (grid.cx + 0.5) * scale - 0.5;
  out.cy = (grid.cy + 0.5) * scale - 0.5;
  return out;
}

RectifiedCamera::RectifiedCamera(RectifiedIntrinsics intrinsics) : intr_(intrinsics) {
  if (intr_.width <= 0 || intr_.height <= 0) {
    throw std::invalid_argument("rectified camera: image size must be positive");
  }
  if (!(intr_.f > 0.0) || !std::isfinite(intr_.f)) {
    throw std::invalid_argument("rectified camera: f must be positive and finite");
  }
  if (!std::isfinite(intr_.cx) || !std::isfinite(intr_.cy)) {
    throw std::invalid_argument("rectified camera: centre is not finite");
  }
}

std::string RectifiedCamera::name() const {
  return intr_.projection == RectifiedProjection::equirectangular ? "equirectangular"
                                                                  : "cylindrical";
}

std::unique_ptr<CameraModel> RectifiedCamera::clone() const {
  return std::make_unique<RectifiedCamera>(*this);
}

double RectifiedCamera::alpha_of_column(double column) const {
  const double t = (column - intr_.cx) / intr_.f;
  return intr_.projection == RectifiedProjection::equirectangular ? t : std::atan(t);
}

double RectifiedCamera::column_of_alpha(double alpha) const {
  const double t =
      intr_.projection == RectifiedProjection::equirectangular ? alpha : std::tan(alpha);
  return intr_.cx + intr_.f * t;
}

double RectifiedCamera::horizontal_field() const {
  return alpha_of_column(intr_.width - 0.5) - alpha_of_column(-0.5);
}

bool RectifiedCamera::unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d& ray) const {
  if (!pixel.allFinite()) return false;
  const double alpha = alpha_of_column(pixel.x());
  const double beta = (pixel.y() - intr_.cy) / intr_.f;
  if (std::abs(alpha) >= M_PI / 2 || std::abs(beta) >= M_PI) return false;
  ray = Eigen::Vector3d(std::sin(alpha), std::cos(alpha) * std::sin(beta),
                        std::cos(alpha) * std::cos(beta));
  return true;
}

bool RectifiedCamera::project(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const {
  if (!ray.allFinite()) return false;
  const double len = ray.norm();
  if (len == 0.0) return false;
  const double alpha = std::asin(std::clamp(ray.x() / len, -1.0, 1.0));
  if (intr_.projection == RectifiedProjection::cylindrical && std::abs(alpha) > 1.55) return false;
  const double beta = std::atan2(ray.y(), ray.z());
  pixel = Eigen::Vector2d(column_of_alpha(alpha), intr_.cy + intr_.f * beta);
  return true;
}

}  // namespace thermovis::camera
