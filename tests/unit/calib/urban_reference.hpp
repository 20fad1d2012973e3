#pragma once
// Reads the published reference calibrations of Urban et al. 2015 (decoded to
// data/calib/ocamcalib_*/reference/urban2015_results.json; conventions in its SOURCES.md).
#include <filesystem>
#include <string>
#include <vector>

#include "thermovis/calib/board.hpp"
#include "thermovis/camera/taylor.hpp"

namespace thermovis::test {

struct UrbanReference {
  std::string method;
  calib::BoardSpec board;               // columns = n_sq_y + 1, rows = n_sq_x + 1
  std::vector<std::string> images;      // the images the method used (file names)
  std::vector<calib::View> views;       // their corners in board order, 0-based (x=col, y=row)
  camera::TaylorIntrinsics intrinsics;  // 0-based centre (row, column)
  double rms_2d_px = 0.0;               // stored rms converted to 2-D RMS
  // Plain (unweighted) 2-D RMS of the stored model and poses over the stored corners, by our
  // own world2cam: equals rms_2d_px except for the Huber-weighted robust method.
  double unweighted_rms_2d_px = 0.0;
};

// `set_folder` is data/calib/ocamcalib_<set>; `method` e.g. "urban_ba_subpixel".
UrbanReference load_urban_reference(const std::filesystem::path& set_folder,
                                    const std::string& method);

// Median and largest distance (px) between two corner grids of the same board, after matching
// the labelling by geometry (the board symmetry that fits best; transposed when the shapes are).
struct GridAgreement {
  double median_px = 0.0;
  double max_px = 0.0;
  double within_1px = 0.0;  // fraction of the corners of a within 1 px of b's
  Eigen::Vector2d worst_a = Eigen::Vector2d::Zero();  // the pair that differs most
  Eigen::Vector2d worst_b = Eigen::Vector2d::Zero();
};
GridAgreement compare_grids(cv::Size grid_a, const std::vector<Eigen::Vector2d>& a, cv::Size grid_b,
                            const std::vector<Eigen::Vector2d>& b);

}  // namespace thermovis::test
