#pragma once
// The Taylor model's world2cam for Ceres (private to the calibration code): the shared
// projection (thermovis/camera/taylor_projection.hpp) on the calibration's parameter blocks.
//
// Intrinsic parameter block, length kIntrinsicsSize:
//   [xc (row), yc (column), c, s (= d = e, the rotation gauge pinned), b0, b2, ..., b_kMaxDegree]
// with the polynomial in a normalised radius rho_n = rho / radius_scale:
//   a_k = b_k / radius_scale^k, so all b_k are of the order of the image size.
// Unused high-order b_k are held at 0 (constant in the problem).
#include <ceres/ceres.h>
#include <ceres/jet.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

#include "thermovis/camera/taylor.hpp"
#include "thermovis/camera/taylor_projection.hpp"

// The projection's root search runs on the Jets' values.
template <int N>
struct thermovis::camera::taylor::ScalarValue<ceres::Jet<double, N>> {
  static double of(const ceres::Jet<double, N>& x) { return x.a; }
};

namespace thermovis::calib::detail {

inline constexpr int kMaxDegree = 6;
inline constexpr int kCoefficientSlots = kMaxDegree;  // b0, b2..b6
inline constexpr int kIntrinsicsSize = 4 + kCoefficientSlots;
inline constexpr int kPoseSize = 6;  // angle-axis (3), translation mm (3); p_cam = R p + t

// The calibration's radius search, in the normalised radius: tighter than TaylorCamera's, since
// the cost's derivatives are taken at the root.
inline constexpr camera::taylor::RadiusSearch kRadiusSearch{40, 1e-13, 1e-13, 1e-15};

// The shared projection's view of an intrinsic block: the full polynomial a0, a1 = 0, a2, ...
// in rho / radius_scale, built in `pol` (kMaxDegree + 1 values).
template <typename T>
camera::taylor::Parameters<T> parameters(const T* intr, double radius_scale, T* pol) {
  pol[0] = intr[4];
  pol[1] = T(0.0);
  for (int k = 2; k <= kMaxDegree; ++k) pol[k] = intr[4 + k - 1];
  return {{intr[0], intr[1], intr[2], intr[3], intr[3]}, pol, kMaxDegree + 1, radius_scale};
}

// Sensor radius (normalised) of an observed pixel under the current intrinsics (doubles):
// the starting point of the root search, so the root found is the one near the observation.
inline double observed_radius(const double* intr, double radius_scale, const Eigen::Vector2d& px) {
  const camera::taylor::Affine<double> affine{intr[0], intr[1], intr[2], intr[3], intr[3]};
  double u = 0.0, v = 0.0;
  camera::taylor::pixel_to_sensor(affine, px.x(), px.y(), u, v);
  return std::hypot(u, v) / radius_scale;
}

// Projects a point in the camera frame (x right, y down, z forward; any unit) to a pixel
// (x = column, y = row). rho_start: normalised radius to start the root search from.
template <typename T>
bool project_point(const T* intr, double radius_scale, const T* p, double rho_start, T* pixel) {
  T pol[kMaxDegree + 1];
  const double start = std::max(rho_start, 1e-6);
  return camera::taylor::project(
      parameters(intr, radius_scale, pol), p, [start](double) { return start; }, kRadiusSearch,
      pixel[0], pixel[1]);
}

// Residual of one corner: projected - observed (px), for a board pose block.
struct CornerResidual {
  Eigen::Vector3d board_point;  // mm
  Eigen::Vector2d observed;     // px
  double radius_scale;

  template <typename T>
  bool operator()(const T* intr, const T* pose, T* residual) const {
    T pb[3] = {T(board_point.x()), T(board_point.y()), T(board_point.z())};
    T p[3];
    ceres::AngleAxisRotatePoint(pose, pb, p);
    for (int i = 0; i < 3; ++i) p[i] += pose[3 + i];
    return finish(intr, p, residual);
  }

  template <typename T>
  bool finish(const T* intr, const T* p, T* residual) const {
    double intr_d[kIntrinsicsSize];
    for (int i = 0; i < kIntrinsicsSize; ++i) intr_d[i] = camera::taylor::value_of(intr[i]);
    T pixel[2];
    if (!project_point(intr, radius_scale, p, observed_radius(intr_d, radius_scale, observed),
                       pixel))
      return false;
    residual[0] = pixel[0] - observed.x();
    residual[1] = pixel[1] - observed.y();
    return true;
  }
};

// The same corner seen by a second camera of a stereo pair: p_second = T_second_first p_first.
struct SecondCameraCornerResidual {
  CornerResidual corner;

  template <typename T>
  bool operator()(const T* intr, const T* pose_first, const T* second_from_first,
                  T* residual) const {
    T pb[3] = {T(corner.board_point.x()), T(corner.board_point.y()), T(corner.board_point.z())};
    T p1[3], p2[3];
    ceres::AngleAxisRotatePoint(pose_first, pb, p1);
    for (int i = 0; i < 3; ++i) p1[i] += pose_first[3 + i];
    ceres::AngleAxisRotatePoint(second_from_first, p1, p2);
    for (int i = 0; i < 3; ++i) p2[i] += second_from_first[3 + i];
    return corner.finish(intr, p2, residual);
  }
};

// Parameter block <-> intrinsics.
std::vector<double> pack_intrinsics(const camera::TaylorIntrinsics& in, double radius_scale);
camera::TaylorIntrinsics unpack_intrinsics(const double* intr, double radius_scale,
                                           int polynomial_degree, cv::Size image_size);

// Holds the unused polynomial slots (and optionally the centre) of a block constant.
void constrain_intrinsics(ceres::Problem& problem, double* intr, int degree, bool refine_centre);
// Levenberg-Marquardt, Schur complement on the poses.
ceres::Solver::Options solver_options(int threads);

// Pose block <-> isometry (mm).
void pack_pose(const Eigen::Isometry3d& T, double* pose);
Eigen::Isometry3d unpack_pose(const double* pose);

}  // namespace thermovis::calib::detail
