#pragma once
// The surface every camera model shares (Taylor/OCamCalib, pinhole, cylindrical rectified).
//
// Frames and units:
//  - pixel: Eigen::Vector2d(x = column, y = row), 0-based, pixel centres at integer coordinates
//    (OpenCV's convention);
//  - ray: a direction in the camera frame, x right, y down, z forward (optical axis); unproject
//    returns it with unit length, project accepts any length > 0.
#include <Eigen/Core>
#include <memory>
#include <opencv2/core/types.hpp>
#include <string>

namespace thermovis::camera {

class CameraModel {
 public:
  virtual ~CameraModel() = default;

  // Short model name, e.g. "taylor".
  virtual std::string name() const = 0;
  // Number of intrinsic parameters (for calibration and reporting).
  virtual int parameter_count() const = 0;
  virtual cv::Size image_size() const = 0;

  // pixel -> unit ray. False where the pixel has no ray in the model's domain.
  virtual bool unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d& ray) const = 0;
  // ray -> pixel. False where the ray is outside the model's valid field (the pixel may lie
  // outside the image even when true: check in_image()).
  virtual bool project(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const = 0;

  virtual std::unique_ptr<CameraModel> clone() const = 0;

  bool in_image(const Eigen::Vector2d& pixel, double margin = 0.0) const {
    const cv::Size size = image_size();
    return pixel.x() >= -0.5 + margin && pixel.y() >= -0.5 + margin &&
           pixel.x() <= size.width - 0.5 - margin && pixel.y() <= size.height - 0.5 - margin;
  }
};

}  // namespace thermovis::camera
