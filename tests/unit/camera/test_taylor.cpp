// The Taylor model against the paper's Tables 1, 4 and 5 and OCamCalib's own files.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "thermovis/camera/field.hpp"
#include "thermovis/camera/ocam_io.hpp"
#include "thermovis/camera/taylor.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/test/paper_rig.hpp"

namespace tc = thermovis::camera;

namespace {

using thermovis::test::paper_taylor_camera;

TEST(Taylor, PaperVisibleLeftHasTable1FieldAndDistortion) {
  const auto f = tc::field_figures(paper_taylor_camera("visible.left"));
  // Table 1: HFOV 124 deg, distortion -45 %.
  EXPECT_NEAR(f.horizontal_deg, 124.0, 1.0);
  EXPECT_NEAR(100.0 * f.corner_distortion, -45.0, 1.0);
  // f = 10.96 mm with 13 um pixels = 843 px; the model's paraxial |a0| = 835.4 px.
  EXPECT_NEAR(f.paraxial_focal_px * 13e-3, 10.96, 0.15);
}

TEST(Taylor, PaperInfraredHasTable2FocalLengthAndWideField) {
  for (const char* name : {"infrared.left", "infrared.right"}) {
    const auto f = tc::field_figures(paper_taylor_camera(name));
    EXPECT_NEAR(f.paraxial_focal_px * 14e-3, 6.0, 0.25) << name;  // Table 2: f = 6 mm
    EXPECT_NEAR(f.horizontal_deg, 121.6, 1.5) << name;            // Table 2: HFOV 121.6 deg
  }
}

// cam2world then world2cam over every pixel of every paper camera: below 0.01 px.
TEST(Taylor, RoundTripBelowHundredthPixelOverEveryPixel) {
  for (const char* name : {"visible.left", "visible.right", "infrared.left", "infrared.right"}) {
    const auto& cam = paper_taylor_camera(name);
    const cv::Size size = cam.image_size();
    double worst = 0.0;
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        Eigen::Vector3d ray;
        Eigen::Vector2d back;
        ASSERT_TRUE(cam.unproject({x, y}, ray));
        ASSERT_TRUE(cam.project(ray, back));
        worst = std::max(worst, (back - Eigen::Vector2d(x, y)).norm());
      }
    }
    EXPECT_LT(worst, 0.01) << name;
  }
}

// The fitted inverse polynomial alone (OCamCalib's world2cam) stays within a bound over the image.
TEST(Taylor, InversePolynomialErrorIsBoundedOverTheImage) {
  for (const char* name : {"visible.left", "visible.right", "infrared.left", "infrared.right"}) {
    const auto f = tc::field_figures(paper_taylor_camera(name), 1);
    EXPECT_LT(f.invpol_max_error_px, 0.02) << name;
  }
}

TEST(Taylor, RejectsRaysOutsideTheField) {
  const auto& cam = paper_taylor_camera("visible.left");
  Eigen::Vector2d px;
  EXPECT_FALSE(cam.project({0.0, 0.0, -1.0}, px));  // straight behind
  EXPECT_FALSE(cam.project({1.0, 0.0, 0.0}, px));   // 90 deg, beyond the 62 deg half field
  EXPECT_TRUE(cam.project({0.0, 0.0, 1.0}, px));
  EXPECT_NEAR(px.x(), 964.3319, 1e-9);  // optical axis lands on the centre (column, row)
  EXPECT_NEAR(px.y(), 487.0978, 1e-9);
}

TEST(Taylor, InvalidIntrinsicsAreRejectedWithTheReason) {
  tc::TaylorIntrinsics in;
  in.width = 100;
  in.height = 100;
  in.xc = 50;
  in.yc = 50;
  in.pol = {300.0, 0.0, 1e-3};
  try {
    tc::TaylorCamera cam(in);
    FAIL() << "positive a0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("a0"), std::string::npos) << e.what();
  }
  in.pol = {-300.0, 0.0, std::nan("")};
  EXPECT_THROW(tc::TaylorCamera{in}, std::invalid_argument);
  in.pol = {-300.0, 0.0, 1e-3};
  in.width = 0;
  EXPECT_THROW(tc::TaylorCamera{in}, std::invalid_argument);
}

TEST(OcamIo, ReadsOcamCalibFileAndAgreesWithItsInversePolynomial) {
  THERMOVIS_REQUIRE_DATA(dir, "calib/ocamcalib_model_only");
  const auto in = tc::read_ocam_calib_results(dir / "calib_results_fisheye_1024x768.txt");
  EXPECT_EQ(in.width, 1024);
  EXPECT_EQ(in.height, 768);
  EXPECT_NEAR(in.xc, 381.777786, 1e-9);  // row
  EXPECT_NEAR(in.yc, 505.480427, 1e-9);  // column
  ASSERT_EQ(in.pol.size(), 5u);
  EXPECT_NEAR(in.pol[0], -551.7655, 1e-6);
  ASSERT_EQ(in.invpol.size(), 8u);
  // Their invpol and our exact inverse agree to about 0.005 px inside the image circle (SOURCES.md
  // measured 0.005 on its own sampling; the worst pixel here is 0.0059).
  const tc::TaylorCamera cam(in);
  double worst = 0.0;
  for (int y = 0; y < 768; y += 4) {
    for (int x = 0; x < 1024; x += 4) {
      if (std::hypot(x - in.yc, y - in.xc) > std::hypot(512.0, 384.0)) continue;
      Eigen::Vector3d ray;
      Eigen::Vector2d exact, theirs;
      ASSERT_TRUE(cam.unproject({x, y}, ray));
      ASSERT_TRUE(cam.project(ray, exact));
      ASSERT_TRUE(cam.project_invpol(ray, theirs));
      worst = std::max(worst, (exact - theirs).norm());
    }
  }
  EXPECT_LT(worst, 0.01);
}

TEST(OcamIo, WriteThenReadGivesTheSameModel) {
  const auto& original = paper_taylor_camera("visible.left").intrinsics();
  std::stringstream text;
  tc::write_ocam_calib_results(original, text);
  const auto back = tc::parse_ocam_calib_results(text, "memory");
  EXPECT_EQ(back.width, original.width);
  EXPECT_EQ(back.height, original.height);
  EXPECT_DOUBLE_EQ(back.xc, original.xc);
  EXPECT_DOUBLE_EQ(back.e, original.e);
  ASSERT_EQ(back.pol.size(), original.pol.size());
  for (size_t i = 0; i < back.pol.size(); ++i)
    EXPECT_NEAR(back.pol[i], original.pol[i], 1e-9 * std::abs(original.pol[i]) + 1e-20);
  ASSERT_EQ(back.invpol.size(), original.invpol.size());
}

TEST(OcamIo, BadFilesNameTheProblem) {
  auto message = [](const std::string& text) {
    std::istringstream in(text);
    try {
      tc::parse_ocam_calib_results(in, "bad.txt");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("5 -551 0 1e-3\n").find("bad.txt"), std::string::npos);
  EXPECT_NE(message("3 -551 0 1e-3\n2 1 2\n1 2\n1 0 0\nabc 1024\n").find("image size"),
            std::string::npos);
  EXPECT_NE(message("4 -551 0 1e-3\n2 1 2\n1 2\n1 0 0\n768 1024\n").find("count"),
            std::string::npos);
  EXPECT_THROW(tc::read_ocam_calib_results("/nonexistent/calib_results.txt"), std::runtime_error);
}

}  // namespace
