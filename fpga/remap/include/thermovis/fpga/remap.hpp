#pragma once
// Remapping an image through a fixed-point table (fixed_map.hpp), two ways that agree bit for
// bit:
//  - remap_reference: the bit-exact model of the FPGA stage (integer arithmetic only, one pixel
//    at a time, reading the full or the quarter table);
//  - FastRemapper: the software fast path, OpenCV's fixed-point cv::remap (CV_16SC2 integer
//    positions + CV_16UC1 1/32 px fractions, precomputed once from the same table).
//
// Bilinear interpolation on the 1/32 px grid: with fractions fx, fy in [0, 31] and the four
// neighbours p00 (row y, column x), p01 (x + 1), p10 (y + 1), p11,
//   acc = (32 - fx)(32 - fy) p00 + fx (32 - fy) p01 + (32 - fx) fy p10 + fx fy p11   (1/1024)
//   8-bit:  out = (acc + 512) >> 10                 (round half up)
//   16-bit: out = acc / 1024 rounded half to even   (OpenCV's float path rounds so; exact while
//           the samples have at most 14 significant bits, the infrared raw format; above that
//           OpenCV's float sums may differ by 1 LSB)
// Neighbours outside the source image count as 0 (constant border); invalid entries give 0.
// Pixel formats: CV_8UC1 (grey), CV_8UC3 (BGR), CV_16UC1 (infrared raw). Output: the table's
// size, the input's type.
#include <opencv2/core/mat.hpp>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"

namespace thermovis::fpga {

// Throws std::invalid_argument when the image type is unsupported or its size is not the
// table's source size.
cv::Mat remap_reference(const cv::Mat& source, const FixedPointMap& map);
cv::Mat remap_reference(const cv::Mat& source, const QuarterTable& table);

class FastRemapper {
 public:
  explicit FastRemapper(const FixedPointMap& map);
  // Same checks as remap_reference; `out` is reallocated only when its size or type differ.
  void remap(const cv::Mat& source, cv::Mat& out) const;
  cv::Mat remap(const cv::Mat& source) const;

  cv::Size size() const { return positions_.size(); }
  cv::Size source_size() const { return source_size_; }
  // Memory of OpenCV's two maps (4 + 2 bytes per output pixel).
  std::size_t map_bytes() const {
    return positions_.total() * positions_.elemSize() + fractions_.total() * fractions_.elemSize();
  }

 private:
  cv::Mat positions_;  // CV_16SC2 integer parts (floor), absolute source px
  cv::Mat fractions_;  // CV_16UC1: fy * 32 + fx
  cv::Size source_size_;
};

// The input check both paths share (type and size), with a message naming what is wrong.
void check_remap_source(const cv::Mat& source, cv::Size expected_size);

}  // namespace thermovis::fpga
