#pragma once
// A planar checkerboard target and the corners seen of it in one image.
//
// Board frame: origin at the first inner corner, x along a row of the board (the `columns`
// direction), y along a column, z = 0 on the board; millimetres. Corner k = r * columns + c
// (row-major, r = 0..rows-1, c = 0..columns-1) lies at (c * square_mm, r * square_mm, 0).
#include <Eigen/Core>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

namespace thermovis::calib {

struct BoardSpec {
  cv::Size inner_corners;  // width = corners per row (columns), height = rows
  double square_mm = 0.0;  // side of one square, mm

  int corner_count() const { return inner_corners.width * inner_corners.height; }
  // The corners in board order, board frame, mm.
  std::vector<Eigen::Vector3d> points() const;
};

// Parses "8x6" (inner corners, columns x rows). Throws std::invalid_argument naming the text.
cv::Size parse_board_size(const std::string& text);

// The corners found in one image, in board order.
struct View {
  std::string name;  // image file name (for messages and reports)
  // (x = column, y = row), px, 0-based pixel centres; NaN = a corner not seen (left out).
  std::vector<Eigen::Vector2d> corners;
};

}  // namespace thermovis::calib
