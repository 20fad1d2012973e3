#pragma once
// Remapping an image through a fixed-point table (fixed_map.hpp), two ways that agree bit for
// bit:
//  - remap_reference: the bit-exact model of the FPGA stage (integer arithmetic only, one pixel
//    at a time, reading the full or the quarter table);
//  - FastRemapper: the software fast path, a vector kernel (Google Highway, dispatched at run
//    time to the CPU's best instruction set: AVX2 on the reference machine) over a layout
//    precomputed once per table: per output pixel its source position in 1/32 px, and per row
//    the runs of pixels that sample nothing (0), that have all four neighbours inside the
//    source (vector path) and that straddle the border (the model's per-pixel path).
//
// Bilinear interpolation on the 1/32 px grid: with fractions fx, fy in [0, 31] and the four
// neighbours p00 (row y, column x), p01 (x + 1), p10 (y + 1), p11,
//   acc = (32 - fx)(32 - fy) p00 + fx (32 - fy) p01 + (32 - fx) fy p10 + fx fy p11   (1/1024)
//   8-bit:  out = (acc + 512) >> 10                 (round half up)
//   16-bit: out = acc / 1024 rounded half to even   (as OpenCV's 16-bit remap, whose float sums
//           agree with it while the samples have at most 14 significant bits, the infrared raw
//           format; both paths here are integer and agree over the whole 16-bit range)
// Neighbours outside the source image count as 0 (constant border); invalid entries give 0.
// Pixel formats: CV_8UC1 (grey), CV_8UC3 (BGR), CV_16UC1 (infrared raw). Output: the table's
// size, the input's type.
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

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
  // Same checks as remap_reference; `out` is reallocated only when its size or type differ
  // (nothing else is allocated per call). With cv::getNumThreads() > 1 the rows are shared
  // among OpenCV's worker threads, the output unchanged.
  void remap(const cv::Mat& source, cv::Mat& out) const;
  cv::Mat remap(const cv::Mat& source) const;
  // Only the output rows first_row..last_row (inclusive), bit-identical to those rows of the
  // full remap; the other rows of `out` are left as they are (`out` has the table's full size,
  // allocated when its size or type differ). Throws std::out_of_range unless
  // 0 <= first_row <= last_row < size().height.
  void remap(const cv::Mat& source, cv::Mat& out, int first_row, int last_row) const;

  cv::Size size() const { return size_; }
  cv::Size source_size() const { return source_size_; }
  // Memory of the precomputed layout: 4 bytes per output pixel (as the table itself) plus the
  // runs (12 bytes each, a few per row) and the row index.
  std::size_t map_bytes() const {
    return entries_.size() * sizeof(std::uint32_t) + runs_.size() * sizeof(Run) +
           row_runs_.size() * sizeof(std::int32_t);
  }

 private:
  enum class RunKind : std::uint8_t {
    zero,      // invalid entries and positions with no neighbour in the source: 0
    interior,  // all four neighbours (and the kernel's wider loads) inside: the vector kernel
    border,    // some neighbours outside: the model's per-pixel path
  };
  struct Run {
    std::int32_t begin;  // first output column
    std::int32_t end;    // one past the last
    RunKind kind;
  };

  cv::Size size_;
  cv::Size source_size_;
  // Row-major, the source position of each output pixel in 1/32 px (remap_kernel.hpp's
  // pack_entry): one 4-byte read per pixel, two thirds of the memory of a separate integer
  // position and fraction (a 1870 x 1130 table: 8.5 MB instead of 12.7; no faster in the
  // pipeline's measurements while the kernel gathered its samples).
  std::vector<std::uint32_t> entries_;
  std::vector<Run> runs_;               // all rows' runs, row after row
  std::vector<std::int32_t> row_runs_;  // runs of row v: [row_runs_[v], row_runs_[v + 1])
};

// OpenCV's fixed-point maps of a table for cv::remap (INTER_LINEAR, BORDER_CONSTANT 0): CV_16SC2
// integer parts (floor, absolute source px) and CV_16UC1 fy * 32 + fx. They sample like the
// model (invalid entries land more than a pixel outside the source); for comparisons.
void to_opencv_maps(const FixedPointMap& map, cv::Mat& positions, cv::Mat& fractions);

// The input check both paths share (type and size), with a message naming what is wrong.
void check_remap_source(const cv::Mat& source, cv::Size expected_size);

}  // namespace thermovis::fpga
