#include "thermovis/rectify/stereo_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core/utility.hpp>

#include "thermovis/camera/field.hpp"
#include "thermovis/camera/taylor.hpp"

namespace thermovis::rectify {

StereoGeometry make_stereo_geometry(const camera::Rig& rig, const camera::StereoPair& pair,
                                    const camera::RectifiedIntrinsics& grid) {
  const auto& left = rig.camera(pair.left);
  const auto& right = rig.camera(pair.right);
  const Eigen::Vector3d c_left = left.T_ref_cam.translation();
  const Eigen::Vector3d c_right = right.T_ref_cam.translation();
  const Eigen::Vector3d baseline = c_right - c_left;
  if (baseline.norm() < 1e-6) {
    throw std::invalid_argument("stereo pair " + pair.left + "/" + pair.right +
                                ": camera centres coincide");
  }
  const Eigen::Vector3d x = baseline.normalized();
  Eigen::Vector3d z = left.T_ref_cam.linear().col(2) + right.T_ref_cam.linear().col(2);
  z = (z - z.dot(x) * x).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r << x, y, z;

  StereoGeometry g{pair.left,
                   pair.right,
                   Eigen::Isometry3d::Identity(),
                   Eigen::Isometry3d::Identity(),
                   baseline.norm(),
                   camera::RectifiedCamera(grid)};
  g.T_ref_left_rect.linear() = r;
  g.T_ref_left_rect.translation() = c_left;
  g.T_ref_right_rect.linear() = r;
  g.T_ref_right_rect.translation() = c_right;
  return g;
}

camera::RectifiedIntrinsics grid_matching_camera(const camera::RigCamera& raw, int width) {
  const auto* taylor = dynamic_cast<const camera::TaylorCamera*>(raw.model.get());
  const cv::Size size = raw.model->image_size();
  double f = 0.0;
  if (taylor != nullptr) {
    f = std::abs(taylor->intrinsics().pol.front());
  } else {
    // Any model: px per rad from the centre pixel's neighbours.
    Eigen::Vector3d a, b;
    raw.model->unproject({size.width / 2.0, size.height / 2.0}, a);
    raw.model->unproject({size.width / 2.0 + 1.0, size.height / 2.0}, b);
    f = 1.0 / std::acos(std::clamp(a.dot(b), -1.0, 1.0));
  }
  camera::RectifiedIntrinsics grid;
  grid.width = width;
  grid.f = f;
  // Vertical field of the raw image on its centre column.
  Eigen::Vector3d top, bottom;
  raw.model->unproject({size.width / 2.0, -0.5}, top);
  raw.model->unproject({size.width / 2.0, size.height - 0.5}, bottom);
  const double vfov = std::acos(std::clamp(top.dot(bottom), -1.0, 1.0));
  grid.height = std::max(2, static_cast<int>(std::lround(vfov * f)) / 2 * 2);
  grid.cx = (grid.width - 1) / 2.0;
  grid.cy = (grid.height - 1) / 2.0;
  grid.projection = camera::RectifiedProjection::equirectangular;
  return grid;
}

camera::RectifiedIntrinsics default_pair_grid(const camera::Rig& rig,
                                              const camera::StereoPair& pair,
                                              camera::RectifiedProjection projection) {
  camera::RectifiedIntrinsics grid = grid_matching_camera(rig.camera(pair.left), 2);
  grid.projection = projection;
  const StereoGeometry g = make_stereo_geometry(rig, pair, grid);
  // Grid coordinates per unit f: column = alpha (or tan alpha), row = beta.
  const camera::RectifiedCamera unit({2, 2, 1.0, 0.0, 0.0, projection});
  double col_min = 0.0, col_max = 0.0, row_min = 0.0, row_max = 0.0;
  auto extend = [&unit](const Eigen::Vector3d& ray, double& lo, double& hi, bool column) {
    Eigen::Vector2d p;
    if (!unit.project(ray, p)) return;
    const double value = column ? p.x() : p.y();
    lo = std::min(lo, value);
    hi = std::max(hi, value);
  };
  for (const auto& [name, T_ref_rect] :
       {std::pair{pair.left, g.T_ref_left_rect}, std::pair{pair.right, g.T_ref_right_rect}}) {
    const camera::RigCamera& cam = rig.camera(name);
    const Eigen::Matrix3d R_rect_cam = T_ref_rect.linear().transpose() * cam.T_ref_cam.linear();
    const cv::Size size = cam.model->image_size();
    // The outer edges near their midpoints (the middle tenth): each eye's whole width and
    // height along its centre lines (the fisheye's corners reach farther and are cut).
    for (int i = 0; i <= 16; ++i) {
      const double t = 0.45 + 0.1 * i / 16.0;
      Eigen::Vector3d ray;
      for (double x : {-0.5, size.width - 0.5}) {
        if (cam.model->unproject({x, t * size.height}, ray)) {
          extend(R_rect_cam * ray, col_min, col_max, true);
        }
      }
      for (double y : {-0.5, size.height - 0.5}) {
        if (cam.model->unproject({t * size.width, y}, ray)) {
          extend(R_rect_cam * ray, row_min, row_max, false);
        }
      }
    }
  }
  // Even sizes; the rounding margin split on both sides. Pixel edges at -0.5 and size - 0.5.
  grid.width = 2 * static_cast<int>(std::ceil(grid.f * (col_max - col_min) / 2.0));
  grid.height = 2 * static_cast<int>(std::ceil(grid.f * (row_max - row_min) / 2.0));
  grid.cx = -0.5 - grid.f * col_min + (grid.width - grid.f * (col_max - col_min)) / 2.0;
  grid.cy = -0.5 - grid.f * row_min + (grid.height - grid.f * (row_max - row_min)) / 2.0;
  return grid;
}

cv::Mat build_map(const camera::RigCamera& cam, const Eigen::Isometry3d& T_ref_rect,
                  const camera::RectifiedCamera& grid, double registration_distance_m,
                  cv::Rect roi) {
  const cv::Size size = grid.image_size();
  if (roi.area() == 0) roi = cv::Rect(0, 0, size.width, size.height);
  roi &= cv::Rect(0, 0, size.width, size.height);
  cv::Mat map(roi.size(), CV_32FC2, cv::Scalar(-1.0f, -1.0f));
  const Eigen::Isometry3d T_cam_rect = cam.T_ref_cam.inverse() * T_ref_rect;
  const bool at_infinity = !(registration_distance_m > 0.0);
  cv::parallel_for_(cv::Range(0, roi.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      auto* out = map.ptr<cv::Vec2f>(v);
      for (int u = 0; u < roi.width; ++u) {
        Eigen::Vector3d ray;
        if (!grid.unproject({u + roi.x, v + roi.y}, ray)) continue;
        const Eigen::Vector3d in_cam =
            at_infinity ? Eigen::Vector3d(T_cam_rect.linear() * ray)
                        : Eigen::Vector3d(T_cam_rect * (ray * registration_distance_m));
        Eigen::Vector2d px;
        if (!cam.model->project(in_cam, px)) continue;
        out[u] = cv::Vec2f(static_cast<float>(px.x()), static_cast<float>(px.y()));
      }
    }
  });
  return map;
}

void bin_map(cv::Mat& map, int bin) {
  if (bin <= 1) return;
  map.forEach<cv::Vec2f>([bin](cv::Vec2f& p, const int*) {
    if (p[0] == -1.0f && p[1] == -1.0f) return;  // no ray: stays the sentinel
    p = cv::Vec2f((p[0] + 0.5f) / static_cast<float>(bin) - 0.5f,
                  (p[1] + 0.5f) / static_cast<float>(bin) - 0.5f);
  });
}

cv::Rect raw_box_on_grid(const camera::RigCamera& cam, const Eigen::Isometry3d& T_ref_rect,
                         const camera::RectifiedCamera& grid, double x_min, double y_min,
                         double x_max, double y_max) {
  const Eigen::Matrix3d R_rect_cam = T_ref_rect.rotation().transpose() * cam.T_ref_cam.rotation();
  std::vector<Eigen::Vector3d> rays;
  const int steps = 16;
  for (int i = 0; i <= steps; ++i) {
    const double t = static_cast<double>(i) / steps;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(x_min + t * (x_max - x_min), y_min),
                                     Eigen::Vector2d(x_min + t * (x_max - x_min), y_max),
                                     Eigen::Vector2d(x_min, y_min + t * (y_max - y_min)),
                                     Eigen::Vector2d(x_max, y_min + t * (y_max - y_min))}) {
      Eigen::Vector3d ray;
      if (cam.model->unproject(p, ray)) rays.push_back(R_rect_cam * ray);
    }
  }
  return rays_box_on_grid(grid, rays);
}

cv::Rect rays_box_on_grid(const camera::RectifiedCamera& grid,
                          const std::vector<Eigen::Vector3d>& rays) {
  double lo_x = 1e30, lo_y = 1e30, hi_x = -1e30, hi_y = -1e30;
  for (const Eigen::Vector3d& ray : rays) {
    Eigen::Vector2d q;
    if (!grid.project(ray, q)) continue;
    lo_x = std::min(lo_x, q.x());
    lo_y = std::min(lo_y, q.y());
    hi_x = std::max(hi_x, q.x());
    hi_y = std::max(hi_y, q.y());
  }
  if (lo_x > hi_x) return {};
  const int x0 = static_cast<int>(std::floor(lo_x)), y0 = static_cast<int>(std::floor(lo_y));
  return {x0, y0, static_cast<int>(std::ceil(hi_x)) - x0 + 1,
          static_cast<int>(std::ceil(hi_y)) - y0 + 1};
}

}  // namespace thermovis::rectify
