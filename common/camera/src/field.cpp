#include "thermovis/camera/field.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace thermovis::camera {
namespace {

double angle_deg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

Eigen::Vector3d ray_at(const TaylorCamera& cam, double x, double y) {
  Eigen::Vector3d ray = Eigen::Vector3d::Zero();
  cam.unproject({x, y}, ray);
  return ray;
}

}  // namespace

FieldFigures field_figures(const TaylorCamera& cam, int stride) {
  const auto& in = cam.intrinsics();
  const double w = in.width, h = in.height;
  const double row0 = in.xc, col0 = in.yc;
  FieldFigures f;
  // Outer edges of the outer pixels.
  f.horizontal_deg = angle_deg(ray_at(cam, -0.5, row0), ray_at(cam, w - 0.5, row0));
  f.vertical_deg = angle_deg(ray_at(cam, col0, -0.5), ray_at(cam, col0, h - 0.5));
  f.diagonal_deg = std::max(angle_deg(ray_at(cam, -0.5, -0.5), ray_at(cam, w - 0.5, h - 0.5)),
                            angle_deg(ray_at(cam, w - 0.5, -0.5), ray_at(cam, -0.5, h - 0.5)));
  f.paraxial_focal_px = std::abs(in.pol.front());
  double best = -1.0;
  for (double x : {-0.5, w - 0.5}) {
    for (double y : {-0.5, h - 0.5}) {
      const Eigen::Vector3d ray = ray_at(cam, x, y);
      const double phi = std::acos(std::clamp(ray.z(), -1.0, 1.0));
      if (phi <= best) continue;
      best = phi;
      // The radius on the sensor of this ray, and what a pinhole would give.
      const double r = cam.radius_at_field_angle(phi);
      const double r_ideal = f.paraxial_focal_px * std::tan(phi);
      f.corner_angle_deg = phi * 180.0 / M_PI;
      f.corner_distortion = phi < M_PI / 2 ? (r - r_ideal) / r_ideal : -1.0;
    }
  }
  const int step = std::max(1, stride);
  for (int y = 0; y < in.height; y += step) {
    for (int x = 0; x < in.width; x += step) {
      Eigen::Vector3d ray;
      Eigen::Vector2d exact, poly;
      if (!cam.unproject({x, y}, ray) || !cam.project(ray, exact) || !cam.project_invpol(ray, poly))
        continue;
      f.invpol_max_error_px = std::max(f.invpol_max_error_px, (exact - poly).norm());
    }
  }
  return f;
}

}  // namespace thermovis::camera
