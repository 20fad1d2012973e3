#include "thermovis/fpga/quarter_table.hpp"

#include <algorithm>
#include <cstdlib>
#include <sstream>
#include <stdexcept>

namespace thermovis::fpga {

namespace {

// The entry mirrored about the vertical (flip_x) and/or horizontal (flip_y) centre line.
FixedPointEntry mirrored(FixedPointEntry e, bool flip_x, bool flip_y) {
  if (!e.valid()) return e;
  return {static_cast<std::int16_t>(flip_x ? -e.qx : e.qx),
          static_cast<std::int16_t>(flip_y ? -e.qy : e.qy)};
}

}  // namespace

SymmetryReport check_quarter_symmetry(const FixedPointMap& map, double tolerance_px) {
  SymmetryReport report;
  const cv::Size size = map.size();
  if (size.width % 2 != 0 || size.height % 2 != 0) {
    report.reason = "output size " + std::to_string(size.width) + "x" +
                    std::to_string(size.height) +
                    " is not even in both directions (a quarter must be exactly 1/4)";
    return report;
  }
  int worst_u = 0, worst_v = 0;
  int max_dev_q5 = 0;
  for (int v = 0; v < size.height; ++v) {
    for (int u = 0; u < size.width; ++u) {
      const FixedPointEntry e = map.at(u, v);
      // Partners: horizontal mirror (x offset negated) and vertical mirror (y offset negated).
      const FixedPointEntry partners[2] = {mirrored(map.at(size.width - 1 - u, v), true, false),
                                           mirrored(map.at(u, size.height - 1 - v), false, true)};
      for (const FixedPointEntry& p : partners) {
        if (e.valid() != p.valid()) {
          ++report.mismatched_validity;
          continue;
        }
        if (!e.valid()) continue;
        const int dev = std::max(std::abs(e.qx - p.qx), std::abs(e.qy - p.qy));
        if (dev > max_dev_q5) {
          max_dev_q5 = dev;
          worst_u = u;
          worst_v = v;
        }
      }
    }
  }
  report.max_deviation_px = max_dev_q5 / double(kSubpixelSteps);
  std::ostringstream why;
  if (report.mismatched_validity > 0) {
    why << report.mismatched_validity
        << " entries are valid where their mirror partner is not (the field is not symmetric)";
  } else if (report.max_deviation_px > tolerance_px) {
    why << "entry (" << worst_u << ", " << worst_v << ") differs from its mirror partner by "
        << report.max_deviation_px << " px, more than the tolerance " << tolerance_px
        << " px (the map is not centred on the source centre, or the lens/rotation is "
           "asymmetric)";
  }
  report.reason = why.str();
  report.symmetric = report.reason.empty();
  return report;
}

QuarterTable QuarterTable::from_map(const FixedPointMap& map, double tolerance_px) {
  const SymmetryReport report = check_quarter_symmetry(map, tolerance_px);
  if (!report.symmetric) {
    throw std::invalid_argument("quarter table refused: " + report.reason);
  }
  QuarterTable table;
  table.full_size_ = map.size();
  table.source_size_ = map.source_size();
  table.quarter_ =
      map.entries()(cv::Rect(0, 0, map.size().width / 2, map.size().height / 2)).clone();
  return table;
}

FixedPointEntry QuarterTable::at(int u, int v) const {
  const int half_w = full_size_.width / 2;
  const int half_h = full_size_.height / 2;
  const bool flip_x = u >= half_w;
  const bool flip_y = v >= half_h;
  const auto& q = quarter_.at<cv::Vec2s>(flip_y ? full_size_.height - 1 - v : v,
                                         flip_x ? full_size_.width - 1 - u : u);
  return mirrored({q[0], q[1]}, flip_x, flip_y);
}

FixedPointMap QuarterTable::expand() const {
  cv::Mat entries(full_size_, CV_16SC2);
  for (int v = 0; v < full_size_.height; ++v) {
    auto* row = entries.ptr<cv::Vec2s>(v);
    for (int u = 0; u < full_size_.width; ++u) {
      const FixedPointEntry e = at(u, v);
      row[u] = cv::Vec2s(e.qx, e.qy);
    }
  }
  return FixedPointMap(entries, source_size_);
}

}  // namespace thermovis::fpga
