#pragma once
// The rectified stereo grid: a projection whose rows are epipolar lines for a baseline along the
// camera frame's x axis, and that keeps a 120+ deg field (a pinhole target cannot).
//
// For a ray r = (x, y, z) (x along the baseline, y down, z forward):
//   alpha = asin(x / |r|)   angle out of the plane perpendicular to the baseline (the paper's
//                           beta_1/beta_2 of Eq. 31 are these angles);
//   beta  = atan2(y, z)     rotation about the baseline: one value per epipolar plane.
// Every epipolar plane contains the baseline, so it is one value of beta: one row in both eyes.
//   equirectangular: column = cx + f * alpha,      row = cy + f * beta
//   cylindrical:     column = cx + f * tan(alpha), row = cy + f * beta   (a cylinder around the
//                    baseline; disparity is then pinhole-like: f * B / d = distance from the
//                    baseline axis)
// f is in px per radian at the centre (px for cylindrical columns).
#include "thermovis/camera/camera_model.hpp"

namespace thermovis::camera {

enum class RectifiedProjection { equirectangular, cylindrical };

struct RectifiedIntrinsics {
  int width = 0, height = 0;
  double f = 0.0;             // px per rad (rows, and columns of equirectangular)
  double cx = 0.0, cy = 0.0;  // px, the ray (0, 0, 1)
  RectifiedProjection projection = RectifiedProjection::equirectangular;
};

// The same field on a grid resampled by `scale` (0.5: half the columns and rows, f halved);
// pixel centres stay at integers, so cx' = (cx + 0.5) scale - 0.5. Sizes round up to even.
RectifiedIntrinsics scaled(const RectifiedIntrinsics& grid, double scale);

class RectifiedCamera final : public CameraModel {
 public:
  explicit RectifiedCamera(RectifiedIntrinsics intrinsics);

  std::string name() const override;
  int parameter_count() const override { return 3; }
  cv::Size image_size() const override { return {intr_.width, intr_.height}; }
  bool unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d& ray) const override;
  bool project(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const override;
  std::unique_ptr<CameraModel> clone() const override;

  const RectifiedIntrinsics& intrinsics() const { return intr_; }
  // Angle alpha (rad) of a column, and column of an angle.
  double alpha_of_column(double column) const;
  double column_of_alpha(double alpha) const;
  // Horizontal field covered by the image width, rad.
  double horizontal_field() const;

 private:
  RectifiedIntrinsics intr_;
};

}  // namespace thermovis::camera
