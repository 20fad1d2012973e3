// The fixed-point remap tables of fpga/remap: format, quarter storage, bit-exact model against
// the fast path (on every instruction set its kernel is compiled for), table export.
#include <gtest/gtest.h>

#include <hwy/targets.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <random>
#include <stdexcept>
#include <string>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/fpga/table_export.hpp"
#include "thermovis/rectify/elliptical.hpp"
#include "thermovis/rectify/rig_rectification.hpp"
#include "thermovis/rectify/stereo_geometry.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/test/paper_rig.hpp"

namespace {

using namespace thermovis;

using test::paper_rig;
using test::paper_taylor_camera;

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

TEST(Remap, Full16BitRangeIsBitExact) {
  // Both paths are integer: no 14-bit limit (cv::remap's float sums had one).
  const cv::Size source(320, 240);
  const auto table = fpga::FixedPointMap::from_float(random_map({160, 120}, source, 5), source);
  const cv::Mat image = random_image(source, CV_16UC1, 65535, 9);
  EXPECT_EQ(count_differences(fpga::remap_reference(image, table),
                              fpga::FastRemapper(table).remap(image)),
            0);
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

// The fast path on every instruction set its kernel is compiled for and this CPU runs (AVX2,
// SSE4, SSSE3, emulated 128-bit or scalar here), each forced in turn.
std::vector<std::int64_t> kernel_targets() {
  const auto targets = hwy::SupportedAndGeneratedTargets();
  EXPECT_GE(targets.size(), 2u) << "the kernel should be compiled for several instruction sets";
  return targets;
}

struct ForcedTarget {
  explicit ForcedTarget(std::int64_t target) { hwy::SetSupportedTargetsForTest(target); }
  ~ForcedTarget() { hwy::SetSupportedTargetsForTest(0); }  // 0: back to the CPU's own
};

int type_max(int type) { return type == CV_16UC1 ? 65535 : 255; }

const char* type_label(int type) {
  return type == CV_8UC1 ? "grey8" : type == CV_8UC3 ? "bgr8" : "grey16";
}

// Every target's FastRemapper output equals the model on `image`.
void expect_bit_exact_on_every_target(const cv::Mat& image, const fpga::FixedPointMap& table,
                                      const std::string& what) {
  const cv::Mat model = fpga::remap_reference(image, table);
  const fpga::FastRemapper fast(table);
  for (const std::int64_t target : kernel_targets()) {
    const ForcedTarget forced(target);
    const cv::Mat out = fast.remap(image);
    ASSERT_EQ(out.size(), model.size()) << what;
    ASSERT_EQ(out.type(), model.type()) << what;
    EXPECT_EQ(count_differences(out, model), 0) << what << " on " << hwy::TargetName(target);
  }
}

// The rig's real tables: the left cameras onto the visible pair's grid at the pipeline's scale
// (0.5: 936x566; wide angle, with invalid entries beyond the field of view and a border where
// the source ends), the paper's elliptical correction (full image, invalid corners), and the
// visible camera binned by 2 onto the pipeline's grid (what rectify-fuse remaps: about a source
// pixel per grid pixel, the grey kernel's windows).
struct RigTable {
  std::string name;
  fpga::FixedPointMap table;
};

const RigTable& rig_table(int index) {
  static std::map<int, RigTable> tables;
  if (auto it = tables.find(index); it != tables.end()) return it->second;
  const auto& rig = paper_rig();
  const bool infrared = index % 2 == 1;
  const std::string camera = infrared ? rig.infrared.left : rig.visible.left;
  const int bin = index == 4 ? 2 : 1;
  const cv::Size source = rig.camera(camera).model->image_size() / bin;
  RigTable t;
  if (index < 2 || index == 4) {
    const auto grid = camera::scaled(
        rectify::default_pair_grid(rig, rig.visible, camera::RectifiedProjection::equirectangular),
        0.5);
    const auto geometry = rectify::make_stereo_geometry(rig, rig.visible, grid);
    t.name = camera + (bin > 1 ? " binned rectified" : " rectified");
    cv::Mat map =
        rectify::build_map(rig.camera(camera), geometry.T_ref_left_rect, geometry.grid, 0.0);
    rectify::bin_map(map, bin);
    t.table = fpga::FixedPointMap::from_float(map, source);
  } else {
    t.name = camera + " elliptical";
    t.table = fpga::FixedPointMap::from_float(
        rectify::build_elliptical_map(
            rectify::fit_elliptical_model(paper_taylor_camera(camera)).model),
        source);
  }
  return tables.emplace(index, std::move(t)).first->second;
}

// Valid entries with some but not all of their four neighbours inside the source.
int straddling_entries(const fpga::FixedPointMap& table) {
  int count = 0;
  const cv::Size source = table.source_size();
  for (int v = 0; v < table.size().height; ++v) {
    for (int u = 0; u < table.size().width; ++u) {
      const cv::Point2d p = table.source_position(u, v);
      if (std::isnan(p.x)) continue;
      const int x0 = static_cast<int>(std::floor(p.x)), y0 = static_cast<int>(std::floor(p.y));
      const bool inside = x0 >= 0 && y0 >= 0 && x0 + 1 < source.width && y0 + 1 < source.height;
      count += inside ? 0 : 1;
    }
  }
  return count;
}

class FastRemapOnRigTables : public ::testing::TestWithParam<std::tuple<int, int>> {};

TEST_P(FastRemapOnRigTables, IsBitIdenticalToTheModel) {
  const auto [index, type] = GetParam();
  const RigTable& t = rig_table(index);
  // The tables hold what the border path needs (pixels whose 2x2 neighbourhood straddles the
  // source's edge), the rectified ones also entries that sample nothing.
  ASSERT_GT(straddling_entries(t.table), 0) << t.name;
  if (index < 2 || index == 4) {
    ASSERT_EQ(t.table.size(), cv::Size(936, 566)) << t.name;
    ASSERT_LT(t.table.valid_entries(), static_cast<std::size_t>(t.table.size().area())) << t.name;
  }
  const cv::Mat image =
      random_image(t.table.source_size(), type, type_max(type), 100 + static_cast<unsigned>(index));
  expect_bit_exact_on_every_target(image, t.table, t.name + " " + type_label(type));
}

std::string rig_table_test_name(
    const ::testing::TestParamInfo<FastRemapOnRigTables::ParamType>& param_info) {
  static const char* names[] = {"VisibleRectified", "InfraredRectified", "VisibleElliptical",
                                "InfraredElliptical", "VisibleBinnedRectified"};
  return std::string(names[std::get<0>(param_info.param)]) + "_" +
         type_label(std::get<1>(param_info.param));
}

INSTANTIATE_TEST_SUITE_P(PaperRig, FastRemapOnRigTables,
                         ::testing::Combine(::testing::Values(0, 1, 2, 3, 4),
                                            ::testing::Values(CV_8UC1, CV_8UC3, CV_16UC1)),
                         rig_table_test_name);

// Raw Q11.5 entries of every kind: random offsets over the whole int16 range (mostly far outside
// the source), positions within two pixels of the source (inside, straddling the edges, just
// beyond), invalid entries, and entries with one coordinate at the invalid value.
fpga::FixedPointMap random_entries(cv::Size out, cv::Size source, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_int_distribution<int> any(INT16_MIN, INT16_MAX), pick(0, 19);
  std::uniform_int_distribution<int> x(-2 * 32, (source.width + 1) * 32),
      y(-2 * 32, (source.height + 1) * 32);
  cv::Mat entries(out, CV_16SC2);
  const auto offset = [](int absolute_q5, int side) {
    return static_cast<short>(absolute_q5 - (side - 1) * (fpga::kSubpixelSteps / 2));
  };
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      const int k = pick(gen);
      cv::Vec2s e(offset(x(gen), source.width), offset(y(gen), source.height));
      if (k == 0) e = cv::Vec2s(fpga::kInvalidEntry, fpga::kInvalidEntry);
      if (k == 1) e = cv::Vec2s(static_cast<short>(any(gen)), static_cast<short>(any(gen)));
      if (k == 2) e[0] = fpga::kInvalidEntry;
      if (k == 3) e[1] = fpga::kInvalidEntry;
      entries.at<cv::Vec2s>(v, u) = e;
    }
  }
  return fpga::FixedPointMap(entries, source);
}

TEST(FastRemap, OddSizesAndEveryKindOfEntryAreBitExact) {
  // Output widths from 1 to 19 and a few longer odd ones put every remainder of the vector
  // width (4, 8, 16 lanes) into the runs' tails; sources of 1 and 2 px have no interior at all.
  const std::vector<cv::Size> sources = {{33, 17}, {640, 479}, {1, 1}, {2, 3}, {3, 2}};
  unsigned seed = 1;
  for (const cv::Size source : sources) {
    for (int width : {1, 2, 3, 5, 7, 8, 9, 13, 15, 16, 17, 19, 37, 101}) {
      const auto table = random_entries({width, 7}, source, seed++);
      for (int type : {CV_8UC1, CV_8UC3, CV_16UC1}) {
        const cv::Mat image = random_image(source, type, type_max(type), seed++);
        expect_bit_exact_on_every_target(
            image, table,
            std::to_string(width) + " px from " + std::to_string(source.width) + "x" +
                std::to_string(source.height) + " " + type_label(type));
      }
    }
  }
}

TEST(FastRemap, LongInteriorRunsWithOddWidthsAreBitExact) {
  // Smooth maps (long interior runs, as the rig's) of odd widths: full vectors, then the tail.
  const cv::Size source(101, 77);
  for (int width : {29, 63, 97, 131}) {
    cv::Mat map(9, width, CV_32FC2);
    for (int v = 0; v < map.rows; ++v) {
      for (int u = 0; u < width; ++u) {
        map.at<cv::Vec2f>(v, u) = {-0.7f + u * 0.79f, 3.3f + v * 8.1f + u * 0.13f};
      }
    }
    const auto table = fpga::FixedPointMap::from_float(map, source);
    for (int type : {CV_8UC1, CV_8UC3, CV_16UC1}) {
      expect_bit_exact_on_every_target(random_image(source, type, type_max(type), 7), table,
                                       std::to_string(width) + " px " + type_label(type));
    }
  }
}

// A smooth map: x = x0 + scale u, rows climbing by `slope` a pixel and bent by `bend` (a
// parabola whose top is at column `top`), v adding `row_step` source rows.
cv::Mat smooth_map(cv::Size out, float x0, float y0, float scale, float slope, float bend,
                   float top, float row_step) {
  cv::Mat map(out, CV_32FC2);
  for (int v = 0; v < out.height; ++v) {
    for (int u = 0; u < out.width; ++u) {
      const float du = static_cast<float>(u) - top;
      map.at<cv::Vec2f>(v, u) = {
          x0 + scale * static_cast<float>(u),
          y0 + row_step * static_cast<float>(v) + slope * static_cast<float>(u) + bend * du * du};
    }
  }
  return map;
}

// A grey image whose last byte is the last before an unreadable page: a read past the image's
// end faults instead of passing unnoticed.
class ImageBeforeGuardPage {
 public:
  ImageBeforeGuardPage(cv::Size size, unsigned seed) {
    page_ = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    const std::size_t bytes = static_cast<std::size_t>(size.area());
    length_ = (bytes + page_ - 1) / page_ * page_ + page_;
    void* memory =
        mmap(nullptr, length_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (memory == MAP_FAILED) throw std::runtime_error("mmap failed");
    base_ = static_cast<std::uint8_t*>(memory);
    if (mprotect(base_ + length_ - page_, page_, PROT_NONE) != 0)
      throw std::runtime_error("mprotect failed");
    image_ = cv::Mat(size, CV_8UC1, base_ + length_ - page_ - bytes);
    random_image(size, CV_8UC1, 255, seed).copyTo(image_);
  }
  ~ImageBeforeGuardPage() { munmap(base_, length_); }
  ImageBeforeGuardPage(const ImageBeforeGuardPage&) = delete;
  ImageBeforeGuardPage& operator=(const ImageBeforeGuardPage&) = delete;
  const cv::Mat& image() const { return image_; }

 private:
  std::size_t page_ = 0, length_ = 0;
  std::uint8_t* base_ = nullptr;
  cv::Mat image_;
};

TEST(FastRemap, SmoothGreyMapsOfEveryScaleAndRowSlopeAreBitExact) {
  // The 8-bit grey kernel's windows (16 bytes of three source rows per 8 pixels) hold a block
  // whose columns lie within 15 px and whose rows within one of each other; the others go the
  // gather way. Scales from 0.5 to 2.2 source px a pixel (windows that fit, and that do not),
  // rows climbing and falling by up to 0.3 px a pixel or turning inside a block, maps reaching
  // the source's last row and right edge (where a window would read past the image's end), in
  // a continuous image that ends before an unreadable page and in a view of a larger one.
  const cv::Mat parent = random_image({260, 150}, CV_8UC1, 255, 11);
  const cv::Size source(233, 121);
  const ImageBeforeGuardPage guarded(source, 12);
  const std::vector<cv::Mat> images = {guarded.image(),
                                       parent(cv::Rect(9, 13, source.width, source.height))};
  const cv::Size out(101, 23);
  for (const float scale : {0.5f, 0.93f, 1.0f, 1.7f, 1.9f, 2.2f}) {
    for (const float slope : {0.0f, 0.05f, -0.05f, 0.3f, -0.3f}) {
      for (const float bend : {0.0f, 0.004f, -0.004f}) {
        // Ending exactly on the last row and column (the bottom-right map), and in the middle.
        const float width = scale * static_cast<float>(out.width - 1);
        const float rise = slope * static_cast<float>(out.width - 1);
        for (const bool at_end : {false, true}) {
          const float x0 = at_end ? static_cast<float>(source.width) - 1.02f - width : 3.4f;
          const float y_end = static_cast<float>(source.height) - 1.01f;
          const float y0 =
              at_end ? y_end - 22.0f * 1.5f - std::max(0.0f, rise) - std::abs(bend) * 60.0f * 60.0f
                     : 40.3f - std::min(0.0f, rise);
          const auto table = fpga::FixedPointMap::from_float(
              smooth_map(out, x0, y0, scale, slope, bend, 37.5f, 1.5f), source);
          for (std::size_t k = 0; k < images.size(); ++k) {
            expect_bit_exact_on_every_target(
                images[k], table,
                "scale " + std::to_string(scale) + " slope " + std::to_string(slope) + " bend " +
                    std::to_string(bend) + (at_end ? " at the end" : "") + (k ? " (view)" : ""));
          }
        }
      }
    }
  }
}

TEST(FastRemap, ReadsAViewIntoALargerImage) {
  // A source that is a region of a larger image (row pitch > width): the last row's loads must
  // stay inside the view's rows, the others may read the parent's padding.
  const cv::Mat parent = random_image({700, 500}, CV_8UC3, 255, 4);
  const cv::Mat view = parent(cv::Rect(31, 17, 640, 479));
  ASSERT_FALSE(view.isContinuous());
  const auto table =
      fpga::FixedPointMap::from_float(random_map({301, 150}, view.size(), 8), view.size());
  expect_bit_exact_on_every_target(view, table, "view");
  cv::Mat grey;
  cv::extractChannel(parent, grey, 1);
  expect_bit_exact_on_every_target(grey(cv::Rect(1, 2, 640, 479)), table, "grey view");
}

TEST(FastRemap, ReusesTheOutputAndReallocatesOnlyWhenItDiffers) {
  const RigTable& t = rig_table(1);
  const cv::Mat image = random_image(t.table.source_size(), CV_16UC1, (1 << 14) - 1, 5);
  const fpga::FastRemapper fast(t.table);
  cv::Mat out(t.table.size(), CV_16UC1);
  const uchar* before = out.data;
  fast.remap(image, out);
  EXPECT_EQ(out.data, before);
  EXPECT_EQ(count_differences(out, fpga::remap_reference(image, t.table)), 0);
  cv::Mat wrong(10, 10, CV_8UC1);
  fast.remap(image, wrong);
  EXPECT_EQ(wrong.size(), t.table.size());
  EXPECT_EQ(wrong.type(), CV_16UC1);
  // The layout: 4 bytes per output pixel (as the table) plus a few runs per row.
  EXPECT_GE(fast.map_bytes(), 4u * static_cast<std::size_t>(t.table.size().area()));
  EXPECT_LT(fast.map_bytes(), 5u * static_cast<std::size_t>(t.table.size().area()));
}

TEST(FastRemap, RowRangeWritesExactlyItsRows) {
  const RigTable& t = rig_table(0);
  const cv::Mat image = random_image(t.table.source_size(), CV_8UC3, 255, 6);
  const cv::Mat model = fpga::remap_reference(image, t.table);
  const fpga::FastRemapper fast(t.table);
  const cv::Scalar untouched(7, 77, 177);
  for (const auto& [first, last] : {std::pair{0, 0}, {13, 200}, {400, 565}, {565, 565}}) {
    cv::Mat out(t.table.size(), CV_8UC3, untouched);
    fast.remap(image, out, first, last);
    // Its rows are the model's, the others as they were.
    cv::Mat expected(t.table.size(), CV_8UC3, untouched);
    model.rowRange(first, last + 1).copyTo(expected.rowRange(first, last + 1));
    EXPECT_EQ(count_differences(out, expected), 0) << first << ".." << last;
  }
  // An empty `out` gets the full size, only the asked rows written.
  cv::Mat fresh;
  fast.remap(image, fresh, 100, 101);
  EXPECT_EQ(fresh.size(), t.table.size());
  EXPECT_EQ(count_differences(fresh.rowRange(100, 102), model.rowRange(100, 102)), 0);
}

TEST(FastRemap, WorkerThreadsGiveTheSameImage) {
  const RigTable& t = rig_table(0);
  const int threads = cv::getNumThreads();
  for (const int type : {CV_8UC3, CV_16UC1}) {
    const cv::Mat image =
        random_image(t.table.source_size(), type, type == CV_8UC3 ? 255 : 16383, 8);
    const cv::Mat model = fpga::remap_reference(image, t.table);
    const fpga::FastRemapper fast(t.table);
    for (const int n : {2, 3, 7}) {
      cv::setNumThreads(n);
      cv::Mat out;
      fast.remap(image, out);
      EXPECT_EQ(count_differences(out, model), 0) << n << " threads, type " << type;
    }
  }
  cv::setNumThreads(threads);
}

TEST(FastRemap, RejectsBadRowsAndImagesWithAMessage) {
  const cv::Size source(64, 48);
  const fpga::FastRemapper fast(
      fpga::FixedPointMap::from_float(random_map({8, 6}, source, 1), source));
  const cv::Mat image(source, CV_8UC1, cv::Scalar(0));
  cv::Mat out;
  for (const auto& [first, last] : {std::pair{-1, 2}, {3, 2}, {0, 6}}) {
    try {
      fast.remap(image, out, first, last);
      FAIL() << first << ".." << last;
    } catch (const std::out_of_range& e) {
      EXPECT_NE(
          std::string(e.what()).find("rows " + std::to_string(first) + ".." + std::to_string(last)),
          std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find("0..5"), std::string::npos) << e.what();
    }
  }
  // The image checks are the model's, with its messages.
  try {
    fast.remap(cv::Mat(40, 64, CV_8UC1, cv::Scalar(0)), out, 0, 1);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("64x40"), std::string::npos) << e.what();
  }
  try {
    fast.remap(cv::Mat(source, CV_16SC1, cv::Scalar(0)));
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("unsupported pixel format"), std::string::npos)
        << e.what();
  }
}

// The paper's elliptical correction: its table is quarter symmetric (Fig. 14).
class QuarterTableOfPaperModel : public ::testing::TestWithParam<std::string> {};

TEST_P(QuarterTableOfPaperModel, StoresAQuarterAndRemapsIdentically) {
  const auto& cam = paper_taylor_camera(GetParam());
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
  const auto& cam = paper_taylor_camera("infrared.right");
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
