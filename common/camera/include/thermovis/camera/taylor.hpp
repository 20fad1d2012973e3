#pragma once
// The Taylor (Scaramuzza / OCamCalib) omnidirectional camera model, as the paper's Tables 4
// and 5 use it.
//
// OCamCalib's own frame: a pixel (row, col) relates to sensor coordinates (u, v) by
//   [row; col] = [[c, d], [e, 1]] * [u; v] + [xc; yc]          (xc is the ROW of the centre)
// and its ray is (u, v, a0 + a1 rho + a2 rho^2 + ...), rho = sqrt(u^2 + v^2), with a0 < 0, so
// the optical axis is OCamCalib's -w. This class converts to the shared camera frame of
// camera_model.hpp: x = v (columns), y = u (rows), z = -w (forward); a proper rotation.
//
// world2cam uses the inverse polynomial rho = sum_i invpol[i] * theta^i (lowest order first,
// theta = atan(w / sqrt(u^2 + v^2)), negative for forward rays) as OCamCalib does, then
// refines rho by Newton steps on the forward polynomial, so project() is the exact inverse of
// unproject(); project_invpol() gives OCamCalib's plain polynomial result. The projection's
// math is taylor_projection.hpp's, shared with the calibration.
#include <vector>

#include "thermovis/camera/camera_model.hpp"

namespace thermovis::camera {

// The largest image side a camera model accepts, px: far beyond any sensor (the paper's is 1920),
// small enough that maps and frames of that size can still be allocated.
inline constexpr int kMaxImageSide = 16384;

struct TaylorIntrinsics {
  int width = 0;                     // image width, px
  int height = 0;                    // image height, px
  double xc = 0.0;                   // centre ROW, px, 0-based (OCamCalib's xc)
  double yc = 0.0;                   // centre COLUMN, px, 0-based (OCamCalib's yc)
  double c = 1.0, d = 0.0, e = 0.0;  // affine (stretch) of OCamCalib
  std::vector<double> pol;           // a0, a1, a2, ... (a1 = 0 in OCamCalib), rho in px
  std::vector<double> invpol;        // inverse polynomial, lowest order first; empty = fit it
};

// How well the inverse polynomial reproduces the forward model over the image.
struct InversePolynomialFit {
  std::vector<double> coefficients;  // lowest order first
  double max_error_px = 0.0;         // over rho in [0, rho_max]
  double rho_max_px = 0.0;           // the range fitted (beyond the farthest image corner)
};

class TaylorCamera final : public CameraModel {
 public:
  // Validates the intrinsics (throws std::invalid_argument naming the bad value) and fits the
  // inverse polynomial when none is given.
  explicit TaylorCamera(TaylorIntrinsics intrinsics);

  std::string name() const override { return "taylor"; }
  int parameter_count() const override;
  cv::Size image_size() const override { return {intr_.width, intr_.height}; }
  bool unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d& ray) const override;
  bool project(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const override;
  std::unique_ptr<CameraModel> clone() const override;

  // OCamCalib's world2cam with the inverse polynomial only (no refinement).
  bool project_invpol(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const;

  const TaylorIntrinsics& intrinsics() const { return intr_; }
  // Largest angle from the optical axis that project() accepts, rad.
  double max_field_angle() const { return max_angle_; }
  // Angle from the optical axis of the ray at sensor radius rho (px), rad.
  double field_angle_at_radius(double rho) const;
  // Sensor radius (px) of a ray at angle phi (rad) from the optical axis.
  double radius_at_field_angle(double phi) const;

  // Fits rho(theta) on [0, rho_max] with the lowest degree whose largest error is under
  // tolerance_px (up to max_degree).
  static InversePolynomialFit fit_inverse_polynomial(const std::vector<double>& pol, double rho_max,
                                                     double tolerance_px = 2e-3,
                                                     int max_degree = 24);

 private:
  double invpol_at(double theta) const;
  // Where the radius search for a ray with m = w / sqrt(u^2 + v^2) starts: the inverse
  // polynomial's estimate, px.
  double radius_start(double m) const;

  TaylorIntrinsics intr_;
  double rho_max_ = 0.0;    // fitted / valid sensor radius, px
  double max_angle_ = 0.0;  // rad
};

}  // namespace thermovis::camera
