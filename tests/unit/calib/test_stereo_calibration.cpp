// Stereo Taylor calibration on OpenCV's sample pairs (640x480 pinhole, 9x6 board), against
// OpenCV's own stereo RMS on the same pairs (0.447 px, see data/calib/SOURCES.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>

#include "thermovis/calib/chessboard.hpp"
#include "thermovis/calib/stereo_calibration.hpp"
#include "thermovis/test/data.hpp"

namespace tcal = thermovis::calib;

TEST(StereoCalibration, OpenCvSamplePairs) {
  THERMOVIS_REQUIRE_DATA(dir, "calib/opencv_stereo/images");
  const tcal::BoardSpec board{{9, 6}, 25.0};  // 25 mm squares (left_intrinsics.yml's 0.025 m)
  std::vector<tcal::View> left, right;
  cv::Size size;
  int pairs = 0;
  for (int k = 1; k <= 14; ++k) {
    char l[32], r[32];
    std::snprintf(l, sizeof l, "left%02d.jpg", k);
    std::snprintf(r, sizeof r, "right%02d.jpg", k);
    if (!std::filesystem::exists(dir / l)) continue;
    ++pairs;
    const cv::Mat li = tcal::read_image((dir / l).string()),
                  ri = tcal::read_image((dir / r).string());
    size = li.size();
    const auto dl = tcal::detect_chessboard(li, board.inner_corners);
    const auto dr = tcal::detect_chessboard(ri, board.inner_corners);
    if (!dl.found || !dr.found) continue;
    left.push_back({l, dl.corners});
    right.push_back({r, dr.corners});
  }
  EXPECT_EQ(pairs, 13);
  EXPECT_EQ(left.size(), 13u);
  const auto cal = tcal::calibrate_stereo(left, right, board, size, size);
  const Eigen::Vector3d t = cal.T_right_left.translation();
  const double angle = Eigen::AngleAxisd(cal.T_right_left.rotation()).angle() * 180.0 / M_PI;
  std::cout << "opencv_stereo: mono rms " << cal.left.rms_2d_px << " / " << cal.right.rms_2d_px
            << " px; stereo rms " << cal.rms_2d_px << " px over " << cal.pairs_used
            << " pairs; T = " << t.transpose() << " mm, rotation " << angle << " deg; a0 "
            << cal.left_intrinsics.pol[0] << " / " << cal.right_intrinsics.pol[0]
            << "; corners rejected " << cal.corners_rejected << "\n";
  for (const auto* mono : {&cal.left, &cal.right})
    for (const auto& v : mono->views)
      if (!v.used) std::cout << "dropped " << v.name << " rms " << v.rms_2d_px << "\n";
  EXPECT_EQ(cal.pairs_used, 13);
  EXPECT_LE(cal.rms_2d_px, 0.45);
  // OpenCV's own stereo calibration: T = (-3.344, 0.042, 0.053) squares, R about 0.3 deg.
  EXPECT_NEAR(t.x(), -3.344 * 25.0, 0.03 * 3.344 * 25.0);
  EXPECT_NEAR(t.y(), 0.042 * 25.0, 1.5);
  EXPECT_NEAR(t.z(), 0.053 * 25.0, 2.5);
  EXPECT_LT(angle, 1.0);
  // OpenCV's fx = 535.9 px; the Taylor a0 is the paraxial focal length.
  EXPECT_NEAR(-cal.left_intrinsics.pol[0], 535.9, 15.0);
}

TEST(StereoCalibration, TooFewPairsIsAClearError) {
  const tcal::BoardSpec board{{9, 6}, 25.0};
  std::vector<tcal::View> two(2, tcal::View{"x", std::vector<Eigen::Vector2d>(54)});
  EXPECT_THROW(tcal::calibrate_stereo(two, two, board, {640, 480}, {640, 480}),
               std::invalid_argument);
}
