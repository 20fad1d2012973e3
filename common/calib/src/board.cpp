#include "thermovis/calib/board.hpp"

#include <regex>
#include <stdexcept>

namespace thermovis::calib {

std::vector<Eigen::Vector3d> BoardSpec::points() const {
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(static_cast<size_t>(corner_count()));
  for (int r = 0; r < inner_corners.height; ++r)
    for (int c = 0; c < inner_corners.width; ++c)
      pts.emplace_back(c * square_mm, r * square_mm, 0.0);
  return pts;
}

cv::Size parse_board_size(const std::string& text) {
  static const std::regex pattern(R"(\s*(\d+)\s*[xX]\s*(\d+)\s*)");
  std::smatch m;
  if (!std::regex_match(text, m, pattern))
    throw std::invalid_argument("board size '" + text +
                                "' is not COLUMNSxROWS of inner corners (e.g. 8x6)");
  const int w = std::stoi(m[1].str()), h = std::stoi(m[2].str());
  if (w < 2 || h < 2 || w > 100 || h > 100)
    throw std::invalid_argument("board size '" + text + "': each side needs 2..100 inner corners");
  return {w, h};
}

}  // namespace thermovis::calib
