// Checkerboard detection on the OCamCalib sample sets, against the corners Urban et al. 2015
// used (their sub-pixel method).
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include "thermovis/calib/chessboard.hpp"
#include "thermovis/test/data.hpp"
#include "urban_reference.hpp"

namespace tcal = thermovis::calib;
namespace tt = thermovis::test;

namespace {

struct SetCase {
  const char* folder;
  cv::Size board;    // as a user gives it (columns x rows of inner corners)
  int min_detected;  // images detected, out of the set
  int images;
};

void check_set(const SetCase& set) {
  THERMOVIS_REQUIRE_DATA(dir, std::string("calib/") + set.folder);
  const auto ref = tt::load_urban_reference(dir, "urban_ba_subpixel");
  const auto files = tcal::list_image_files((dir / "images").string());
  ASSERT_EQ(static_cast<int>(files.size()), set.images);
  int detected = 0, compared = 0;
  for (const auto& file : files) {
    const auto det = tcal::detect_chessboard(tcal::read_image(file), set.board);
    const std::string name = std::filesystem::path(file).filename().string();
    std::cout << set.folder << " " << name << ": "
              << (det.found ? det.method : std::string("not found"))
              << (det.missing > 0 ? " missing " + std::to_string(det.missing) : std::string());
    if (det.found) {
      ++detected;
      for (const auto& view : ref.views) {
        if (view.name != name) continue;
        const auto agree =
            tt::compare_grids(set.board, det.corners, ref.board.inner_corners, view.corners);
        std::cout << "  vs reference: median " << agree.median_px << " px, max " << agree.max_px
                  << " at (" << agree.worst_a.transpose() << ") vs (" << agree.worst_b.transpose()
                  << ")";
        EXPECT_LT(agree.median_px, 0.5) << name;
        // Nearly every corner within 1 px; a rare one can sit on an occluder (MiniOmni12).
        EXPECT_GE(agree.within_1px, 0.97) << name;
        ++compared;
      }
    }
    std::cout << "\n";
  }
  std::cout << set.folder << ": detected " << detected << "/" << files.size() << ", " << compared
            << " compared with the reference\n";
  EXPECT_GE(detected, set.min_detected);
}

}  // namespace

TEST(Chessboard, Fisheye1) { check_set({"ocamcalib_fisheye1", {8, 6}, 15, 15}); }
TEST(Chessboard, VmrImage) { check_set({"ocamcalib_vmrimage", {6, 7}, 10, 10}); }
TEST(Chessboard, Ladybug) { check_set({"ocamcalib_ladybug", {5, 8}, 9, 9}); }
TEST(Chessboard, MiniOmni) { check_set({"ocamcalib_miniomni", {7, 11}, 15, 15}); }
TEST(Chessboard, KaidanOmni) { check_set({"ocamcalib_kaidanomni", {7, 11}, 6, 17}); }

TEST(Chessboard, CanonicalOrderIsStableUnderRelabelling) {
  // A synthetic grid, rotated 20 degrees: every symmetric relabelling maps back to one order.
  const cv::Size grid(5, 4);
  std::vector<Eigen::Vector2d> pts;
  const double a = 20.0 * M_PI / 180.0;
  for (int r = 0; r < grid.height; ++r)
    for (int c = 0; c < grid.width; ++c)
      pts.emplace_back(100 + 30 * (c * std::cos(a) - r * std::sin(a)),
                       80 + 30 * (c * std::sin(a) + r * std::cos(a)));
  auto reference = pts;
  tcal::canonical_order(grid, reference);
  EXPECT_NEAR((reference.front() - pts.front()).norm(), 0.0, 1e-12);
  std::vector<Eigen::Vector2d> reversed(pts.rbegin(), pts.rend());
  tcal::canonical_order(grid, reversed);
  for (size_t k = 0; k < pts.size(); ++k)
    EXPECT_NEAR((reversed[k] - reference[k]).norm(), 0, 1e-12);
}

TEST(Chessboard, BadInputIsRejected) {
  EXPECT_THROW(tcal::detect_chessboard(cv::Mat(), {8, 6}), std::invalid_argument);
  EXPECT_THROW(tcal::detect_chessboard(cv::Mat(10, 10, CV_32FC1), {8, 6}), std::invalid_argument);
  EXPECT_FALSE(tcal::detect_chessboard(cv::Mat(120, 160, CV_8UC1, cv::Scalar(7)), {8, 6}).found);
  EXPECT_THROW(tcal::read_image("/nonexistent/board.png"), std::runtime_error);
  EXPECT_THROW(tcal::parse_board_size("8by6"), std::invalid_argument);
  EXPECT_EQ(tcal::parse_board_size("8x6"), cv::Size(8, 6));
}
