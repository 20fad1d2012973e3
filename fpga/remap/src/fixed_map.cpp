#include "thermovis/fpga/fixed_map.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace thermovis::fpga {

namespace {

void check_source_size(cv::Size source_size) {
  if (source_size.width <= 0 || source_size.height <= 0 || source_size.width > kMaxSourceSide ||
      source_size.height > kMaxSourceSide) {
    throw std::invalid_argument(
        "fixed-point map: source size " + std::to_string(source_size.width) + "x" +
        std::to_string(source_size.height) + " is outside 1.." + std::to_string(kMaxSourceSide) +
        " px per side (the Q11.5 offsets cover +-1024 px around the source centre)");
  }
}

// Offset from the centre in 1/32 px, rounded half away from zero so that mirrored positions
// quantise to exactly negated offsets.
std::int16_t quantise(double position, int source_side) {
  const double offset = (position - (source_side - 1) / 2.0) * kSubpixelSteps;
  return static_cast<std::int16_t>(std::round(offset));
}

}  // namespace

FixedPointMap FixedPointMap::from_float(const cv::Mat& map_xy, cv::Size source_size) {
  if (map_xy.type() != CV_32FC2 || map_xy.empty()) {
    throw std::invalid_argument("fixed-point map: expected a non-empty CV_32FC2 float map");
  }
  check_source_size(source_size);
  cv::Mat entries(map_xy.size(), CV_16SC2);
  for (int v = 0; v < map_xy.rows; ++v) {
    const auto* in = map_xy.ptr<cv::Vec2f>(v);
    auto* out = entries.ptr<cv::Vec2s>(v);
    for (int u = 0; u < map_xy.cols; ++u) {
      const double x = in[u][0];
      const double y = in[u][1];
      // Strictly inside (-1, size): beyond that, no neighbour of the position is in the image.
      const bool valid = std::isfinite(x) && std::isfinite(y) && x > -1.0 &&
                         x < source_size.width && y > -1.0 && y < source_size.height;
      out[u] = valid ? cv::Vec2s(quantise(x, source_size.width), quantise(y, source_size.height))
                     : cv::Vec2s(kInvalidEntry, kInvalidEntry);
    }
  }
  return FixedPointMap(entries, source_size);
}

FixedPointMap::FixedPointMap(cv::Mat entries, cv::Size source_size)
    : entries_(std::move(entries)), source_size_(source_size) {
  if (entries_.type() != CV_16SC2 || entries_.empty()) {
    throw std::invalid_argument("fixed-point map: expected a non-empty CV_16SC2 table");
  }
  check_source_size(source_size_);
}

cv::Point2d FixedPointMap::source_position(int u, int v) const {
  const FixedPointEntry e = at(u, v);
  if (!e.valid()) {
    return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
  }
  return {absolute_q5(e.qx, source_size_.width) / double(kSubpixelSteps),
          absolute_q5(e.qy, source_size_.height) / double(kSubpixelSteps)};
}

cv::Mat FixedPointMap::to_float() const {
  cv::Mat out(entries_.size(), CV_32FC2);
  for (int v = 0; v < entries_.rows; ++v) {
    auto* row = out.ptr<cv::Vec2f>(v);
    for (int u = 0; u < entries_.cols; ++u) {
      const cv::Point2d p = source_position(u, v);
      row[u] = std::isnan(p.x) ? cv::Vec2f(-1.0f, -1.0f)
                               : cv::Vec2f(static_cast<float>(p.x), static_cast<float>(p.y));
    }
  }
  return out;
}

std::size_t FixedPointMap::valid_entries() const {
  std::size_t count = 0;
  for (int v = 0; v < entries_.rows; ++v) {
    for (int u = 0; u < entries_.cols; ++u) count += at(u, v).valid() ? 1 : 0;
  }
  return count;
}

}  // namespace thermovis::fpga
