#pragma once
// Images the unit tests share: seeded stereo captures and exact comparison (OpenCV core only;
// header-only, so test_support itself needs no OpenCV).
#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>

namespace thermovis::test {

// Four seeded random images in capture order (visible left, visible right, infrared left,
// infrared right): the visible ones 8-bit BGR of `visible` pixels, the infrared ones 14-bit
// counts in CV_16UC1 of `infrared` pixels. Another seed gives other images in every camera.
inline std::array<cv::Mat, 4> seeded_capture(std::uint64_t seed, cv::Size visible,
                                             cv::Size infrared) {
  cv::RNG rng(seed);
  std::array<cv::Mat, 4> images;
  for (std::size_t i = 0; i < images.size(); ++i) {
    cv::Mat& image = images[i];
    if (i < 2) {
      image.create(visible, CV_8UC3);
      rng.fill(image, cv::RNG::UNIFORM, 0, 256);
    } else {
      image.create(infrared, CV_16UC1);
      rng.fill(image, cv::RNG::UNIFORM, 0, 16384);
    }
  }
  return images;
}

// Same size, type and every pixel.
inline bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

}  // namespace thermovis::test
