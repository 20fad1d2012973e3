#pragma once
// The Taylor model's world2cam written for Ceres (private to the calibration code).
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
#include <cmath>
#include <vector>

#include "thermovis/camera/taylor.hpp"

namespace thermovis::calib::detail {

inline constexpr int kMaxDegree = 6;
inline constexpr int kCoefficientSlots = kMaxDegree;  // b0, b2..b6
inline constexpr int kIntrinsicsSize = 4 + kCoefficientSlots;
inline constexpr int kPoseSize = 6;  // angle-axis (3), translation mm (3); p_cam = R p + t

inline double value_of(double x) { return x; }
template <int N>
double value_of(const ceres::Jet<double, N>& x) {
  return x.a;
}

// Polynomial g(rho_n) = sum b_k rho_n^k - m_scaled rho_n and its derivative, b1 = 0.
template <typename T>
T poly_minus_line(const T* b, const T& m_scaled, const T& x) {
  T value = b[kCoefficientSlots - 1];
  for (int k = kCoefficientSlots - 2; k >= 1; --k) value = value * x + b[k];
  // value = b2 + b3 x + ... ; full = b0 + x^2 * value
  return b[0] + x * x * value - m_scaled * x;
}

inline double dpoly_minus_line(const double* b, double m_scaled, double x) {
  // d/dx [b0 + sum_{k>=2} b_k x^k] = sum k b_k x^(k-1)
  double value = 0.0;
  for (int k = kCoefficientSlots - 1; k >= 1; --k) value = value * x + (k + 1) * b[k];
  return x * value - m_scaled;
}

// Sensor radius (normalised) of an observed pixel under the current intrinsics (doubles):
// the starting point of the root search, so the root found is the one near the observation.
inline double observed_radius(const double* intr, double radius_scale, const Eigen::Vector2d& px) {
  const double c = intr[2], s = intr[3];
  const double dr = px.y() - intr[0], dc = px.x() - intr[1];
  const double invdet = 1.0 / (c - s * s);
  const double u = invdet * (dr - s * dc), v = invdet * (-s * dr + c * dc);
  return std::hypot(u, v) / radius_scale;
}

// Projects a point in the camera frame (x right, y down, z forward; any unit) to a pixel
// (x = column, y = row). rho_start: normalised radius to start the root search from.
// Newton's method runs in double precision; one last Newton step in T from the converged root
// carries the exact derivatives (implicit function theorem).
template <typename T>
bool project_point(const T* intr, double radius_scale, const T* p, double rho_start, T* pixel) {
  const T U = p[1], V = p[0], W = -p[2];
  const T norm = ceres::sqrt(U * U + V * V + T(1e-300));
  if (!(value_of(norm) > 1e-12)) return false;
  const T m_scaled = W / norm * radius_scale;
  const T* b = intr + 4;
  double bd[kCoefficientSlots];
  for (int k = 0; k < kCoefficientSlots; ++k) bd[k] = value_of(b[k]);
  const double md = value_of(m_scaled);
  double x = std::max(rho_start, 1e-6);
  bool converged = false;
  for (int it = 0; it < 40; ++it) {
    const double g = poly_minus_line(bd, md, x);
    const double dg = dpoly_minus_line(bd, md, x);
    if (!(std::abs(dg) > 1e-15)) return false;
    const double step = g / dg;
    x -= step;
    if (!(x > 0.0) || !std::isfinite(x)) return false;
    if (std::abs(step) < 1e-13 * (1.0 + x)) {
      converged = true;
      break;
    }
  }
  if (!converged) return false;
  const double dg = dpoly_minus_line(bd, md, x);
  const T rho_n = T(x) - poly_minus_line(b, m_scaled, T(x)) / dg;
  const T rho = rho_n * radius_scale;
  const T u = U / norm * rho, v = V / norm * rho;
  const T& c = intr[2];
  const T& s = intr[3];
  pixel[0] = s * u + v + intr[1];      // column
  pixel[1] = c * u + s * v + intr[0];  // row
  return true;
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
    for (int i = 0; i < kIntrinsicsSize; ++i) intr_d[i] = value_of(intr[i]);
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
