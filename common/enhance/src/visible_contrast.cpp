#include "thermovis/enhance/visible_contrast.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::enhance {

void replace_luma(const cv::Mat& bgr, const cv::Mat& luma, const cv::Mat& new_luma, cv::Mat& out) {
  if (bgr.channels() == 1) {
    new_luma.copyTo(out);
    return;
  }
  // Three vectorised OpenCV passes over per-thread buffers.
  thread_local cv::Mat shift, shift3;
  cv::subtract(new_luma, luma, shift, cv::noArray(), CV_16S);
  cv::merge(std::vector<cv::Mat>{shift, shift, shift}, shift3);
  cv::add(bgr, shift3, out, cv::noArray(), CV_8U);
}

void enhance_luma(const cv::Mat& luma, cv::Mat& out, const VisibleContrastParams& params) {
  if (luma.empty()) throw std::invalid_argument("visible enhancement: empty image");
  if (luma.type() != CV_8UC1) {
    throw std::invalid_argument("visible luma enhancement needs CV_8UC1, got " +
                                cv::typeToString(luma.type()));
  }
  if (!(params.clip_limit > 0.0) || params.tiles_x < 1 || params.tiles_y < 1) {
    throw std::invalid_argument("visible enhancement: clip_limit must be > 0 and tiles >= 1");
  }
  // One CLAHE object per thread: it keeps scratch buffers between calls.
  thread_local cv::Ptr<cv::CLAHE> clahe = cv::createCLAHE();
  clahe->setClipLimit(params.clip_limit);
  clahe->setTilesGridSize(cv::Size(params.tiles_x, params.tiles_y));
  clahe->apply(luma, out);
}

cv::Mat enhance_visible(const cv::Mat& visible, const VisibleContrastParams& params) {
  if (visible.empty()) throw std::invalid_argument("visible enhancement: empty image");
  if (visible.type() != CV_8UC1 && visible.type() != CV_8UC3) {
    throw std::invalid_argument("visible enhancement needs CV_8UC1 or CV_8UC3, got " +
                                cv::typeToString(visible.type()));
  }
  cv::Mat out;
  if (visible.channels() == 1) {
    enhance_luma(visible, out, params);
    return out;
  }
  cv::Mat luma, enhanced;
  cv::cvtColor(visible, luma, cv::COLOR_BGR2GRAY);
  enhance_luma(luma, enhanced, params);
  replace_luma(visible, luma, enhanced, out);
  return out;
}

}  // namespace thermovis::enhance
