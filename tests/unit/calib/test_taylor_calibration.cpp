// Mono Taylor calibration on the OCamCalib sample sets, against Urban et al. 2015
// (ISPRS J. 108:72-79) on the same images. Their "rms" of the urban_* methods is per
// coordinate; every figure here is 2-D RMS (see taylor_calibration.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "thermovis/calib/chessboard.hpp"
#include "thermovis/calib/taylor_calibration.hpp"
#include "thermovis/test/data.hpp"
#include "urban_reference.hpp"

namespace tcal = thermovis::calib;
namespace tt = thermovis::test;

namespace {

const char* const kMethods[] = {"ocamcalib_original", "ocamcalib_subpixel", "urban_ba",
                                "urban_ba_subpixel", "urban_robust_ba_subpixel"};

struct SetCase {
  const char* folder;
  cv::Size board;  // as a user gives it
};

// Urban's best published result over the five methods as plain 2-D RMS (the robust method's
// stored figure is Huber-weighted; its plain RMS is recomputed from its model and poses).
std::pair<double, std::string> best_published(const std::filesystem::path& dir) {
  std::pair<double, std::string> best{1e9, ""};
  for (const char* m : kMethods) {
    const auto ref = tt::load_urban_reference(dir, m);
    if (ref.unweighted_rms_2d_px < best.first) best = {ref.unweighted_rms_2d_px, m};
  }
  return best;
}

void report(const std::string& what, const tcal::TaylorCalibration& cal, double best,
            const std::string& best_method, const tt::UrbanReference& ref) {
  const auto& in = cal.intrinsics;
  std::cout << std::fixed << std::setprecision(4) << what << ": rms_2d " << cal.rms_2d_px
            << " px (linear " << cal.linear_rms_2d_px << "), images " << cal.images_used << "/"
            << cal.views.size() << "; Urban best " << best << " (" << best_method << ")"
            << "; a0 " << in.pol[0] << " vs " << ref.intrinsics.pol[0] << ", centre (" << in.xc
            << ", " << in.yc << ") vs (" << ref.intrinsics.xc << ", " << ref.intrinsics.yc
            << "), c " << std::setprecision(5) << in.c << " d=e " << in.d << "; corners left out "
            << cal.corners_rejected << "\n";
}

void expect_close_to_reference(const tcal::TaylorCalibration& cal, const tt::UrbanReference& ref) {
  const auto& in = cal.intrinsics;
  EXPECT_NEAR(in.pol[0], ref.intrinsics.pol[0], 0.01 * std::abs(ref.intrinsics.pol[0]) + 1.0);
  EXPECT_NEAR(in.xc, ref.intrinsics.xc, 3.0);
  EXPECT_NEAR(in.yc, ref.intrinsics.yc, 3.0);
  EXPECT_NEAR(in.c, ref.intrinsics.c, 0.01);
}

// The optimiser alone: Urban's own corners (their sub-pixel set) in, 2-D RMS out.
void calibrate_reference_corners(const SetCase& set) {
  THERMOVIS_REQUIRE_DATA(dir, std::string("calib/") + set.folder);
  const auto ref = tt::load_urban_reference(dir, "urban_ba_subpixel");
  const auto [best, best_method] = best_published(dir);
  const auto cal =
      tcal::calibrate_taylor(ref.views, ref.board, {ref.intrinsics.width, ref.intrinsics.height});
  report(std::string(set.folder) + " (Urban's corners)", cal, best, best_method, ref);
  EXPECT_EQ(cal.images_used, static_cast<int>(ref.views.size()));
  EXPECT_LE(cal.rms_2d_px, best);
  expect_close_to_reference(cal, ref);
}

// The whole chain: our corner detection on the images Urban used, then calibration.
void calibrate_detected_corners(const SetCase& set) {
  THERMOVIS_REQUIRE_DATA(dir, std::string("calib/") + set.folder);
  const auto ref = tt::load_urban_reference(dir, "urban_ba_subpixel");
  const auto [best, best_method] = best_published(dir);
  tcal::BoardSpec board{set.board, ref.board.square_mm};
  std::vector<tcal::View> views;
  cv::Size size;
  for (const auto& name : ref.images) {
    const cv::Mat image = tcal::read_image((dir / "images" / name).string());
    size = image.size();
    const auto det = tcal::detect_chessboard(image, set.board);
    ASSERT_TRUE(det.found) << name;
    views.push_back({name, det.corners});
  }
  const auto cal = tcal::calibrate_taylor(views, board, size);
  report(std::string(set.folder) + " (our corners)", cal, best, best_method, ref);
  EXPECT_EQ(cal.images_used, static_cast<int>(ref.images.size()));
  // Our corners differ from Urban's by a few hundredths of a pixel; on Ladybug that leaves
  // the RMS 0.1 % above theirs, so 0.2 % is allowed here (the optimiser alone, on their own
  // corners above, must be at or below).
  EXPECT_LE(cal.rms_2d_px, 1.002 * best);
  expect_close_to_reference(cal, ref);
}

}  // namespace

TEST(TaylorCalibration, Fisheye1UrbanCorners) {
  calibrate_reference_corners({"ocamcalib_fisheye1", {8, 6}});
}
TEST(TaylorCalibration, VmrImageUrbanCorners) {
  calibrate_reference_corners({"ocamcalib_vmrimage", {6, 7}});
}
TEST(TaylorCalibration, LadybugUrbanCorners) {
  calibrate_reference_corners({"ocamcalib_ladybug", {5, 8}});
}
TEST(TaylorCalibration, MiniOmniUrbanCorners) {
  calibrate_reference_corners({"ocamcalib_miniomni", {7, 11}});
}
TEST(TaylorCalibration, KaidanOmniUrbanCorners) {
  calibrate_reference_corners({"ocamcalib_kaidanomni", {7, 11}});
}

TEST(TaylorCalibration, Fisheye1Detected) {
  calibrate_detected_corners({"ocamcalib_fisheye1", {8, 6}});
}
TEST(TaylorCalibration, VmrImageDetected) {
  calibrate_detected_corners({"ocamcalib_vmrimage", {6, 7}});
}
TEST(TaylorCalibration, LadybugDetected) {
  calibrate_detected_corners({"ocamcalib_ladybug", {5, 8}});
}
TEST(TaylorCalibration, MiniOmniDetected) {
  calibrate_detected_corners({"ocamcalib_miniomni", {7, 11}});
}
TEST(TaylorCalibration, KaidanOmniDetected) {
  calibrate_detected_corners({"ocamcalib_kaidanomni", {7, 11}});
}
