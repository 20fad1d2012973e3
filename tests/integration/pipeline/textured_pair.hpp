#pragma once
// A synthetic rectified pair for the tests that feed match (or any reader of grid frames)
// directly: a blurred-noise texture on the pipeline grid whose right eye is the left shifted
// by `shift` columns, a fronto-parallel scene at one disparity. Only the pixels and `eyes`
// are set; seq, capture time and stamps are the caller's.
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/frames.h"
#include "thermovis/node/frame_codec.hpp"

namespace thermovis::test {

// `type`: CV_8UC1 (grey) or CV_8UC3 (BGR, the fused band's format).
inline void fill_textured_pair(GridStereoFrame& frame, cv::Size grid, int shift, int type) {
  cv::Mat noise(grid, CV_8UC1), blurred;
  cv::RNG rng(42);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(noise, blurred, cv::Size(5, 5), 1.2);
  cv::Mat shifted = cv::Mat::zeros(grid, CV_8UC1);
  blurred.colRange(shift, grid.width).copyTo(shifted.colRange(0, grid.width - shift));
  cv::Mat left = node::prepare(frame, node::Eye::left, grid, type);
  cv::Mat right = node::prepare(frame, node::Eye::right, grid, type);
  if (type == CV_8UC3) {
    cv::cvtColor(blurred, left, cv::COLOR_GRAY2BGR);
    cv::cvtColor(shifted, right, cv::COLOR_GRAY2BGR);
  } else {
    blurred.copyTo(left);
    shifted.copyTo(right);
  }
  frame.eyes(EYES_BOTH);
}

}  // namespace thermovis::test
