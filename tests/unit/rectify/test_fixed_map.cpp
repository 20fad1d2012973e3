// The fixed-point remap tables of fpga/remap: format, quarter storage, bit-exact model against
// the fast path, table export.
#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/core.hpp>
#include <random>
#include <string>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/fpga/table_export.hpp"
#include "thermovis/rectify/elliptical.hpp"
#include "thermovis/rectify/rig_rectification.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/data.hpp"

namespace {

using namespace thermovis;

const camera::Rig& paper_rig() {
  static const camera::Rig rig =
      runtime::load_rig(test::source_root() / "deploy" / "rigs" / "paper.yaml");
  return rig;
}

const camera::TaylorCamera& taylor_of(const std::string& name) {
  return dynamic_cast<const camera::TaylorCamera&>(*paper_rig().camera(name).model);
}

cv::Mat random_image(cv::Size size, int type, int max_value, unsigned seed) {
  cv::Mat image(size, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, max_value + 1);
  return image;
}

// A float map with random sub-pixel positions, some near and beyond the edges, some invalid.
cv::Mat random_map(cv::Size out, cv::Size source, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<float> x(-2.0f, source.width + 1.0f),
      y(-2.0f, source.height + 1.0f);
  std::uniform_int_distribution<int> pick(0, 49);
  cv::Mat map(out, CV_32FC2);
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      const int k = pick(gen);
      map.at<cv::Vec2f>(v, u) = k == 0   ? cv::Vec2f(-1.0f, -1.0f)
                                : k == 1 ? cv::Vec2f(std::nanf(""), 3.0f)
                                : k == 2 ? cv::Vec2f(std::round(x(gen)), std::round(y(gen)))
                                         : cv::Vec2f(x(gen), y(gen));
    }
  }
  return map;
}

int count_differences(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  return cv::countNonZero(diff.reshape(1));
}

TEST(FixedPointMap, QuantisesToQ11_5OffsetsFromTheSourceCentre) {
  const cv::Size source(1920, 1080);
  cv::Mat map(1, 5, CV_32FC2);
  map.at<cv::Vec2f>(0, 0) = {959.5f, 539.5f};          // the centre: offset (0, 0)
  map.at<cv::Vec2f>(0, 1) = {958.0f, 541.5f};          // (-1.5, +2.0) px
  map.at<cv::Vec2f>(0, 2) = {0.0f + 1.0f / 64, 0.0f};  // a tie: rounds away from the centre
  map.at<cv::Vec2f>(0, 3) = {1920.5f, 10.0f};          // beyond a pixel outside: invalid
  map.at<cv::Vec2f>(0, 4) = {-1.0f, -1.0f};            // build_map's no-ray sentinel
  const auto table = fpga::FixedPointMap::from_float(map, source);
  EXPECT_EQ(table.at(0, 0).qx, 0);
  EXPECT_EQ(table.at(0, 0).qy, 0);
  EXPECT_EQ(table.at(1, 0).qx, -48);
  EXPECT_EQ(table.at(1, 0).qy, 64);
  EXPECT_EQ(table.at(2, 0).qx, -30704);  // (0 - 959.5) * 32, the +1/64 tie rounds away from 0
  EXPECT_FALSE(table.at(3, 0).valid());
  EXPECT_FALSE(table.at(4, 0).valid());
  EXPECT_EQ(table.table_bytes(), 5u * 4u);
  EXPECT_DOUBLE_EQ(table.source_position(1, 0).x, 958.0);
  EXPECT_DOUBLE_EQ(table.source_position(1, 0).y, 541.5);
  EXPECT_EQ(fpga::table_word(table.at(1, 0)), 0xffd00040u);
}

TEST(FixedPointMap, RoundTripIsWithinHalfAStep) {
  const cv::Size source(1024, 768);
  const cv::Mat map = random_map({200, 100}, source, 7);
  const auto table = fpga::FixedPointMap::from_float(map, source);
  const cv::Mat back = table.to_float();
  double worst = 0.0;
  for (int v = 0; v < map.rows; ++v) {
    for (int u = 0; u < map.cols; ++u) {
      if (!table.at(u, v).valid()) continue;
      const cv::Vec2f a = map.at<cv::Vec2f>(v, u), b = back.at<cv::Vec2f>(v, u);
      worst = std::max({worst, double(std::abs(a[0] - b[0])), double(std::abs(a[1] - b[1]))});
    }
  }
  EXPECT_LE(worst, 1.0 / 64 + 1e-4);
  EXPECT_GT(worst, 0.0);
}

TEST(FixedPointMap, RejectsWrongInputsWithAMessage) {
  EXPECT_THROW(fpga::FixedPointMap::from_float(cv::Mat(4, 4, CV_32FC1), {100, 100}),
               std::invalid_argument);
  try {
    fpga::FixedPointMap::from_float(cv::Mat(4, 4, CV_32FC2, cv::Scalar(1, 1)), {4096, 100});
    FAIL() << "a source wider than 2046 px must be refused";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("4096x100"), std::string::npos) << e.what();
  }
}

// The fast path (cv::remap, fixed-point maps) and the bit-exact model agree bit for bit.
class RemapAgreement : public ::testing::TestWithParam<int> {};

TEST_P(RemapAgreement, FastPathIsBitIdenticalToTheModel) {
  const int type = GetParam();
  const cv::Size source(640, 480);
  const auto table = fpga::FixedPointMap::from_float(random_map({320, 240}, source, 11), source);
  const int max_value = type == CV_16UC1 ? (1 << 14) - 1 : 255;  // infrared raw: 14 bits
  const cv::Mat image = random_image(source, type, max_value, 3);
  const cv::Mat model = fpga::remap_reference(image, table);
  const cv::Mat fast = fpga::FastRemapper(table).remap(image);
  ASSERT_EQ(model.type(), type);
  ASSERT_EQ(model.size(), table.size());
  EXPECT_EQ(count_differences(model, fast), 0);
  // And the model is a real interpolation: not all zero, within the input's range.
  double lo, hi;
  cv::minMaxLoc(model.reshape(1), &lo, &hi);
  EXPECT_GT(hi, max_value / 2);
}

INSTANTIATE_TEST_SUITE_P(Formats, RemapAgreement, ::testing::Values(CV_8UC1, CV_8UC3, CV_16UC1),
                         [](const auto& param_info) {
                           return param_info.param == CV_8UC1   ? std::string("Grey8")
                                  : param_info.param == CV_8UC3 ? std::string("Bgr8")
                                                                : std::string("Grey16");
                         });

TEST(Remap, Full16BitRangeAgreesWithinOneLsb) {
  const cv::Size source(320, 240);
  const auto table = fpga::FixedPointMap::from_float(random_map({160, 120}, source, 5), source);
  const cv::Mat image = random_image(source, CV_16UC1, 65535, 9);
  cv::Mat diff;
  cv::absdiff(fpga::remap_reference(image, table), fpga::FastRemapper(table).remap(image), diff);
  double worst;
  cv::minMaxLoc(diff, nullptr, &worst);
  EXPECT_LE(worst, 1.0);
}

TEST(Remap, InterpolatesAKnownRamp) {
  // Source value = 8 * column: any position x samples 8 x exactly (up to rounding).
  cv::Mat ramp(4, 32, CV_8UC1);
  for (int u = 0; u < ramp.cols; ++u) ramp.col(u).setTo(8 * u);
  cv::Mat map(1, 3, CV_32FC2);
  map.at<cv::Vec2f>(0, 0) = {10.25f, 1.0f};  // 82
  map.at<cv::Vec2f>(0, 1) = {3.5f, 2.5f};    // 28
  map.at<cv::Vec2f>(0, 2) = {-0.5f, 1.0f};   // half of the pixel is the 0 border: 0
  const auto table = fpga::FixedPointMap::from_float(map, ramp.size());
  const cv::Mat out = fpga::remap_reference(ramp, table);
  EXPECT_EQ(out.at<uchar>(0, 0), 82);
  EXPECT_EQ(out.at<uchar>(0, 1), 28);
  EXPECT_EQ(out.at<uchar>(0, 2), 0);
}

TEST(Remap, RejectsWrongImagesWithAMessage) {
  const cv::Size source(64, 48);
  const auto table = fpga::FixedPointMap::from_float(random_map({8, 8}, source, 1), source);
  try {
    fpga::remap_reference(cv::Mat(40, 64, CV_8UC1, cv::Scalar(0)), table);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("64x40"), std::string::npos) << e.what();
  }
  EXPECT_THROW(fpga::FastRemapper(table).remap(cv::Mat(48, 64, CV_32FC1, cv::Scalar(0))),
               std::invalid_argument);
  EXPECT_THROW(fpga::FastRemapper(table).remap(cv::Mat()), std::invalid_argument);
}

// The paper's elliptical correction: its table is quarter symmetric (Fig. 14).
class QuarterTableOfPaperModel : public ::testing::TestWithParam<std::string> {};

TEST_P(QuarterTableOfPaperModel, StoresAQuarterAndRemapsIdentically) {
  const auto& cam = taylor_of(GetParam());
  const auto fit = rectify::fit_elliptical_model(cam);
  const auto full =
      fpga::FixedPointMap::from_float(rectify::build_elliptical_map(fit.model), cam.image_size());
  const auto report = fpga::check_quarter_symmetry(full, 0.0);  // exactly symmetric
  ASSERT_TRUE(report.symmetric) << report.reason;
  const auto quarter = fpga::QuarterTable::from_map(full);
  EXPECT_EQ(quarter.table_bytes() * 4, full.table_bytes());
  EXPECT_EQ(count_differences(quarter.expand().entries(), full.entries()), 0);

  const bool infrared = GetParam().rfind("infrared", 0) == 0;
  const cv::Mat image = random_image(cam.image_size(), infrared ? CV_16UC1 : CV_8UC3,
                                     infrared ? (1 << 14) - 1 : 255, 21);
  const cv::Mat from_full = fpga::remap_reference(image, full);
  EXPECT_EQ(count_differences(fpga::remap_reference(image, quarter), from_full), 0);
  EXPECT_EQ(count_differences(fpga::FastRemapper(quarter.expand()).remap(image), from_full), 0);
}

INSTANTIATE_TEST_SUITE_P(PaperRig, QuarterTableOfPaperModel,
                         ::testing::Values("visible.left", "infrared.left"),
                         [](const auto& param_info) {
                           std::string name = param_info.param;
                           name.erase(name.find('.'), 1);
                           return name;
                         });

TEST(QuarterTable, RefusesAnAsymmetricMapWithTheReason) {
  // The Taylor rectification of the paper's left visible camera: its centre is (964.3, 487.1),
  // off the image centre, and the rectified frame is rotated: not symmetric.
  const auto& rig = paper_rig();
  camera::RectifiedIntrinsics grid =
      rectify::grid_matching_camera(rig.camera(rig.visible.left), 480);
  grid.f /= 4.0;  // a small grid keeps the test quick
  grid.height /= 4;
  grid.cy = (grid.height - 1) / 2.0;
  grid.cx = (grid.width - 1) / 2.0;
  const auto g = rectify::make_stereo_geometry(rig, rig.visible, grid);
  const auto table = fpga::FixedPointMap::from_float(
      rectify::build_map(rig.camera(rig.visible.left), g.T_ref_left_rect, g.grid), {1920, 1080});
  const auto report = fpga::check_quarter_symmetry(table);
  EXPECT_FALSE(report.symmetric);
  EXPECT_GT(report.max_deviation_px, 1.0);
  try {
    fpga::QuarterTable::from_map(table);
    FAIL() << "an asymmetric map must not be stored as a quarter";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("quarter table refused"), std::string::npos);
  }
  // Odd sizes cannot be split in four equal quarters.
  const auto odd =
      fpga::FixedPointMap::from_float(cv::Mat(3, 4, CV_32FC2, cv::Scalar(5, 5)), {10, 10});
  EXPECT_FALSE(fpga::check_quarter_symmetry(odd).symmetric);
}

TEST(TableExport, HexAndBinRoundTrip) {
  const auto& cam = taylor_of("infrared.right");
  const auto full = fpga::FixedPointMap::from_float(
      rectify::build_elliptical_map(rectify::fit_elliptical_model(cam).model), cam.image_size());
  const auto quarter = fpga::QuarterTable::from_map(full);
  const auto dir = test::temp_dir("table-export");
  fpga::export_table(quarter, dir / "q.hex", fpga::TableFormat::hex);
  fpga::export_table(full, dir / "f.bin", fpga::TableFormat::bin);
  EXPECT_EQ(std::filesystem::file_size(dir / "f.bin"), full.table_bytes());
  EXPECT_EQ(count_differences(
                fpga::read_table(dir / "q.hex", fpga::TableFormat::hex, quarter.quarter().size()),
                quarter.quarter()),
            0);
  EXPECT_EQ(count_differences(fpga::read_table(dir / "f.bin", fpga::TableFormat::bin, full.size()),
                              full.entries()),
            0);
  std::ifstream hex(dir / "q.hex");
  std::string header, first;
  std::getline(hex, header);
  std::getline(hex, first);
  EXPECT_NE(header.find("quarter of 1024x768"), std::string::npos) << header;
  EXPECT_EQ(first.size(), 8u);
  std::filesystem::remove_all(dir);
}

}  // namespace
