#pragma once
// Visible adaptive contrast enhancement for dark and bright regions (the paper's Section 2.3,
// its reference [31]): contrast-limited adaptive histogram equalisation (CLAHE, OpenCV) of the
// BT.601 luma. Each tile's mapping is a clipped histogram equalisation, so dark and bright regions
// are each stretched over their own range, and the clip limit bounds noise amplification. Colour:
// every channel is shifted by Y_enhanced - Y, which keeps BT.601 Cb/Cr (functions of B - Y and
// R - Y) except where a channel saturates; cheaper than a YCrCb round trip.
#include <opencv2/core/mat.hpp>

namespace thermovis::enhance {

struct VisibleContrastParams {
  double clip_limit = 2.0;  // CLAHE clip limit (multiples of the mean bin count)
  int tiles_x = 8;          // tile grid
  int tiles_y = 8;
};

// A BGR image whose BT.601 luma `luma` (CV_8UC1, cv::COLOR_BGR2GRAY of `bgr`) is replaced by
// `new_luma`: every channel shifted by new_luma - luma, saturated. Keeps Cb/Cr where no channel
// saturates. A one-channel `bgr` gives new_luma itself. `out` is reused when it has the size.
void replace_luma(const cv::Mat& bgr, const cv::Mat& luma, const cv::Mat& new_luma, cv::Mat& out);

// CLAHE of a luma plane (CV_8UC1) into `out` (reused when it has the size): what
// enhance_visible does to the luma, for callers that go on working on the luma (fusion).
// Throws std::invalid_argument for another type or bad parameters.
void enhance_luma(const cv::Mat& luma, cv::Mat& out, const VisibleContrastParams& params = {});

// visible: CV_8UC1 or CV_8UC3 (BGR). Returns the same type. Throws std::invalid_argument for
// empty input or another type.
cv::Mat enhance_visible(const cv::Mat& visible, const VisibleContrastParams& params = {});

}  // namespace thermovis::enhance
