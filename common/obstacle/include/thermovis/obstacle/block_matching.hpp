#pragma once
// Block matching along the rows of a rectified pair, the result of OpenCV's cv::StereoBM bit for
// bit (the X-Sobel pre-filter, minimum disparity 0, no regions of interest, no left-right check)
// before its speckle filter, computed with vector kernels (Google Highway, chosen at run time)
// across a row's pixels instead of StereoBM's 128-bit vectors across the disparities.
//
// What it computes, per pixel (x, y) of the left image (OpenCV 4.6, stereobm.cpp):
//  - both images pre-filtered: clamp(x Sobel, -cap, cap) + cap (rows reflected at the top and
//    bottom, 101; the first and last column cap; an odd height's last row cap);
//  - SAD(D) over the block x block window centred on it, left (x, y) against right (x - D, y),
//    for D in [0, disparities); the best: the least SAD, the largest D among equal ones;
//  - none (-16) where its texture, the sum over the window of |pre-filtered - cap|, is under
//    the texture threshold; where another D at least 2 from the best has a SAD of at most
//    best + best * uniqueness_ratio / 100 (integers); outside the window's reach of the borders
//    (x < disparities - 1 + block / 2, x >= width - block / 2, y < block / 2,
//    y >= height - block / 2);
//  - else 16 D, and between 0 and the largest D the parabola's offset through the neighbours'
//    SADs p (D - 1) and n (D + 1): (256 D + (p - n) 256 / (p + n - 2 best + |p - n|) + 15) >> 4.
// tests/unit/obstacle/test_block_matching.cpp compares it with cv::StereoBM on every Highway
// target this CPU runs; tests/bench/obstacle times the two in one run.
#include <opencv2/core/mat.hpp>

namespace thermovis::obstacle {

struct BlockMatchParams {
  int disparities = 32;       // a positive multiple of 16
  int block = 7;              // odd, 5..21 (the SADs then fit 16 bits, as StereoBM's)
  int texture_threshold = 0;  // >= 0
  int uniqueness_ratio = 0;   // %, 0..10000 (0: no test)
  int prefilter_cap = 31;     // 1..31
};

// Whether block_match computes these (else cv::StereoBM, which also gives its own errors for
// what it refuses: sizes, a block as large as the image).
bool block_match_supported(const cv::Mat& left, const cv::Mat& right, const BlockMatchParams& p);

// A pixel without a disparity: StereoBM's minimum disparity (0) less one, in its 1/16 px.
inline constexpr short kBlockMatchNone = -16;

// CV_16S disparity, 1/16 px, kBlockMatchNone where there is none. The inputs are CV_8UC1 of one
// size; throws std::invalid_argument unless block_match_supported.
void block_match(const cv::Mat& left, const cv::Mat& right, const BlockMatchParams& p,
                 cv::Mat& disparity);

}  // namespace thermovis::obstacle
