#pragma once
// Fixed-point remap tables: the format the FPGA stores and the software reference uses.
//
// A table has one entry per OUTPUT pixel (u = column, v = row of the rectified/corrected image)
// and holds the SOURCE (raw image) position to sample there.
//
// Entry format: two int16 words (qx, qy), signed Q11.5 (1 sign bit, 10 integer bits, 5 fraction
// bits: 1/32 px steps, range [-1024, +1023.96875] px), measured from the source image's centre
//   c = ((source_width - 1) / 2, (source_height - 1) / 2)     (px, pixel centres at integers)
// so that source column = c.x + qx / 32, source row = c.y + qy / 32.
// Storing offsets from the centre makes the format fit sources up to 2046 px wide and high (both
// the 1920x1080 visible and 1024x768 infrared sensors) in 16 bits, and makes mirroring exact: the
// entry of the mirrored output pixel is the negated offset, which is what the quarter table
// (quarter_table.hpp) relies on. In units of 1/32 px the absolute position is
//   X = (source_width - 1) * 16 + qx,   Y = (source_height - 1) * 16 + qy,
// integer part X >> 5 (floor), fraction X & 31, the same 1/32 grid as OpenCV's fixed-point remap
// (INTER_BITS = 5), so the fast path (remap.hpp) and the bit-exact model sample identically.
// Invalid entries (no ray, or nothing of the source within one pixel) are (-32768, -32768); they
// sample nothing and produce 0.
#include <cstddef>
#include <cstdint>
#include <opencv2/core/mat.hpp>

namespace thermovis::fpga {

inline constexpr int kFractionBits = 5;
inline constexpr int kSubpixelSteps = 1 << kFractionBits;  // 32 steps per px
inline constexpr std::int16_t kInvalidEntry = INT16_MIN;
inline constexpr int kMaxSourceSide = 2046;  // px, so every valid offset fits in Q11.5

struct FixedPointEntry {
  std::int16_t qx = kInvalidEntry;
  std::int16_t qy = kInvalidEntry;
  bool valid() const { return qx != kInvalidEntry || qy != kInvalidEntry; }
};

// A full table: output size x entries of the format above.
class FixedPointMap {
 public:
  // Quantises a float map (CV_32FC2, x = source column, y = source row, as build_map and
  // cv::remap use it) to the nearest 1/32 px, ties away from zero (symmetric, so a mirror
  // symmetric float map gives an exactly mirror symmetric table). Entries that are not finite,
  // negative sentinels (-1, -1), or farther than one pixel outside the source become invalid.
  // Throws std::invalid_argument on a wrong map type or a source larger than kMaxSourceSide.
  static FixedPointMap from_float(const cv::Mat& map_xy, cv::Size source_size);

  FixedPointMap() = default;
  // Takes a CV_16SC2 table of entries (qx, qy) as is (e.g. an expanded quarter table).
  FixedPointMap(cv::Mat entries, cv::Size source_size);

  cv::Size size() const { return entries_.size(); }  // output image size
  cv::Size source_size() const { return source_size_; }
  const cv::Mat& entries() const { return entries_; }  // CV_16SC2
  FixedPointEntry at(int u, int v) const {
    const auto& e = entries_.at<cv::Vec2s>(v, u);
    return {e[0], e[1]};
  }
  // Source position of an entry in px (NaN for invalid entries).
  cv::Point2d source_position(int u, int v) const;
  // Back to CV_32FC2 (invalid entries as (-1, -1)), e.g. to compare with the float map.
  cv::Mat to_float() const;
  // Storage: output pixels x 4 bytes.
  std::size_t table_bytes() const { return entries_.total() * entries_.elemSize(); }
  std::size_t valid_entries() const;

 private:
  cv::Mat entries_;
  cv::Size source_size_;
};

// Absolute source position of an entry in 1/32 px (see the header comment).
inline int absolute_q5(std::int16_t offset_q5, int source_side) {
  return (source_side - 1) * (kSubpixelSteps / 2) + offset_q5;
}

}  // namespace thermovis::fpga
