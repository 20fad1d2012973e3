#pragma once
// The quarter-symmetric table of the paper's Fig. 14: a map that is mirror symmetric about the
// output image's vertical and horizontal centre lines is stored as its top-left quadrant only,
// and the other three quadrants are read from it with the offsets' signs flipped:
//   entry(u, v) = (sx * q.qx, sy * q.qy),  q = quarter(min(u, W-1-u), min(v, H-1-v)),
//   sx = -1 when u >= W/2, sy = -1 when v >= H/2.
// This is how the FPGA's address generator reads it (one table read per pixel, two sign flips).
// Symmetry needs the map centred on the source centre, with the source centre's offsets 0; in
// the Q11.5 format of fixed_map.hpp mirrored offsets are exact negations.
#include <optional>
#include <string>

#include "thermovis/fpga/fixed_map.hpp"

namespace thermovis::fpga {

struct SymmetryReport {
  bool symmetric = false;
  double max_deviation_px = 0.0;  // largest |entry - mirrored partner| over the table, px
  int mismatched_validity = 0;    // entries valid where their mirror partner is not
  std::string reason;             // why the map is not symmetric (empty when it is)
};

// Compares every entry with its horizontal and vertical mirror partners. Symmetric when the
// output width and height are even, validity matches, and every deviation is <= tolerance_px.
SymmetryReport check_quarter_symmetry(const FixedPointMap& map, double tolerance_px = 1.0 / 32);

class QuarterTable {
 public:
  // Keeps the top-left quadrant of `map`. Throws std::invalid_argument with the symmetry
  // report's reason (largest deviation and where) when the map is not symmetric within
  // tolerance_px: quarter storage of an asymmetric map would move pixels.
  static QuarterTable from_map(const FixedPointMap& map, double tolerance_px = 1.0 / 32);

  cv::Size full_size() const { return full_size_; }
  cv::Size source_size() const { return source_size_; }
  const cv::Mat& quarter() const { return quarter_; }  // CV_16SC2, (H/2) x (W/2)
  FixedPointEntry at(int u, int v) const;              // entry of the full table at (u, v)
  // The full table the quarter stands for.
  FixedPointMap expand() const;
  std::size_t table_bytes() const { return quarter_.total() * quarter_.elemSize(); }

 private:
  cv::Mat quarter_;
  cv::Size full_size_;
  cv::Size source_size_;
};

}  // namespace thermovis::fpga
