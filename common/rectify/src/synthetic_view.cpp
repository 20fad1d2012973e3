#include "thermovis/rectify/synthetic_view.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <stdexcept>

namespace thermovis::rectify {

cv::Mat render_pattern(const camera::RigCamera& camera, const Eigen::Isometry3d& T_ref_pattern,
                       const DirectionalPattern& pattern, int type, int samples) {
  if (type != CV_8UC1 && type != CV_8UC3 && type != CV_16UC1) {
    throw std::invalid_argument("render_pattern: type must be CV_8UC1, CV_8UC3 or CV_16UC1");
  }
  samples = std::max(1, samples);
  const cv::Size size = camera.model->image_size();
  const Eigen::Matrix3d R_pattern_cam =
      T_ref_pattern.linear().transpose() * camera.T_ref_cam.linear();
  const double full_scale =
      type == CV_16UC1 ? std::ldexp(1.0, std::clamp(camera.bit_depth, 1, 16)) - 1.0 : 255.0;
  cv::Mat out(size, type, cv::Scalar::all(0));
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < size.width; ++u) {
        double sum = 0.0;
        int count = 0;
        for (int j = 0; j < samples; ++j) {
          for (int i = 0; i < samples; ++i) {
            const Eigen::Vector2d px(u - 0.5 + (i + 0.5) / samples, v - 0.5 + (j + 0.5) / samples);
            Eigen::Vector3d ray;
            if (!camera.model->unproject(px, ray)) continue;
            sum += std::clamp(pattern(R_pattern_cam * ray), 0.0, 1.0);
            ++count;
          }
        }
        const double value = count > 0 ? std::round(full_scale * sum / count) : 0.0;
        if (type == CV_16UC1) {
          out.at<std::uint16_t>(v, u) = static_cast<std::uint16_t>(value);
        } else if (type == CV_8UC1) {
          out.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(value);
        } else {
          const auto g = static_cast<std::uint8_t>(value);
          out.at<cv::Vec3b>(v, u) = cv::Vec3b(g, g, g);
        }
      }
    }
  });
  return out;
}

DirectionalPattern angular_checkerboard(double square_rad) {
  if (!(square_rad > 0.0)) throw std::invalid_argument("angular_checkerboard: square must be > 0");
  return [square_rad](const Eigen::Vector3d& ray) {
    const double alpha = std::asin(std::clamp(ray.x() / ray.norm(), -1.0, 1.0));
    const double beta = std::atan2(ray.y(), ray.z());
    const long parity = static_cast<long>(std::floor(alpha / square_rad)) +
                        static_cast<long>(std::floor(beta / square_rad));
    return (parity % 2 == 0) ? 0.85 : 0.15;
  };
}

DirectionalPattern angular_spot(const Eigen::Vector3d& centre, double sigma_rad) {
  const Eigen::Vector3d c = centre.normalized();
  return [c, sigma_rad](const Eigen::Vector3d& ray) {
    const double angle = std::atan2(c.cross(ray).norm(), c.dot(ray));
    return std::exp(-0.5 * angle * angle / (sigma_rad * sigma_rad));
  };
}

}  // namespace thermovis::rectify
