// obstacle::block_match against OpenCV's cv::StereoBM, which it reproduces to the bit: textured
// scenes at several disparities, flat patches (the texture test), noise (the uniqueness test),
// images of two or three grey levels (ties everywhere), odd and even sizes, every block, range,
// threshold and ratio the dense stage may use, on every instruction set its kernels are compiled
// for and this CPU runs (each forced in turn).
#include <gtest/gtest.h>
#include <hwy/highway.h>
#include <hwy/targets.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "thermovis/obstacle/block_matching.hpp"
#include "thermovis/obstacle/dense_disparity.hpp"

namespace ob = thermovis::obstacle;

namespace {

struct ForcedTarget {
  explicit ForcedTarget(std::int64_t target) { hwy::SetSupportedTargetsForTest(target); }
  ~ForcedTarget() { hwy::SetSupportedTargetsForTest(0); }  // 0: back to the CPU's own
};

std::vector<std::int64_t> kernel_targets() {
  const auto targets = hwy::SupportedAndGeneratedTargets();
  EXPECT_GE(targets.size(), 2u) << "the kernels should be compiled for several instruction sets";
  return targets;
}

cv::Mat opencv_block_match(const cv::Mat& left, const cv::Mat& right,
                           const ob::BlockMatchParams& p) {
  const cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(p.disparities, p.block);
  bm->setPreFilterType(cv::StereoBM::PREFILTER_XSOBEL);
  bm->setPreFilterCap(p.prefilter_cap);
  bm->setTextureThreshold(p.texture_threshold);
  bm->setUniquenessRatio(p.uniqueness_ratio);
  bm->setSpeckleWindowSize(0);
  cv::Mat out;
  bm->compute(left, right, out);
  return out;
}

// A left image and its right eye: a textured slanted plane, a nearer box, a flat patch (no
// texture) and a band of noise; `levels` grey levels when not 0 (ties between disparities).
struct Pair {
  cv::Mat left, right;
  std::string name;
};

Pair scene(int width, int height, int levels, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> grey(0, 255);
  const int wide = width + 80;
  cv::Mat texture(height, wide, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < wide; ++x)
      texture.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(grey(rng));
  }
  cv::GaussianBlur(texture, texture, cv::Size(5, 5), 1.2);
  Pair p;
  p.name = std::to_string(width) + "x" + std::to_string(height) +
           (levels > 0 ? " levels " + std::to_string(levels) : "");
  p.left.create(height, width, CV_8UC1);
  p.right.create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      // Disparity: the plane's 3 + 10 y / height px, the box's 17 px.
      const bool box =
          x > width / 2 && x < width / 2 + width / 5 && y > height / 4 && y < height / 2;
      const int d = box ? 17 : 3 + (10 * y) / height;
      p.left.at<std::uint8_t>(y, x) = texture.at<std::uint8_t>(y, x + 40);
      p.right.at<std::uint8_t>(y, x) = texture.at<std::uint8_t>(y, x + 40 + d);
    }
  }
  // A flat patch in both eyes and a band of independent noise in the right one.
  p.left(cv::Rect(width / 8, height / 2, width / 5, height / 3)).setTo(90);
  p.right(cv::Rect(width / 8, height / 2, width / 5, height / 3)).setTo(90);
  for (int y = 0; y < height / 6; ++y) {
    for (int x = 0; x < width; ++x)
      p.right.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(grey(rng));
  }
  if (levels > 0) {
    p.left = p.left * (static_cast<double>(levels) / 256.0);
    p.right = p.right * (static_cast<double>(levels) / 256.0);
  }
  return p;
}

int differences(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::compare(a, b, diff, cv::CMP_NE);
  return cv::countNonZero(diff);
}

TEST(BlockMatching, EqualsOpenCvStereoBmOnEveryTarget) {
  const std::vector<Pair> pairs{scene(128, 40, 0, 1), scene(213, 67, 0, 2), scene(96, 31, 0, 3),
                                scene(100, 36, 3, 4), scene(77, 25, 2, 5),  scene(468, 138, 0, 6)};
  struct Settings {
    int texture, ratio, cap;
  };
  const std::vector<Settings> settings{
      {0, 0, 31}, {16, 12, 31}, {250, 20, 31}, {0, 5, 9}, {40, 0, 31}};
  int compared = 0, matched_pixels = 0;
  for (const std::int64_t target : kernel_targets()) {
    const ForcedTarget forced(target);
    for (const Pair& pair : pairs) {
      for (const int disparities : {16, 32, 64}) {
        for (const int block : {5, 7, 11, 21}) {
          for (const Settings& s : settings) {
            const ob::BlockMatchParams p{disparities, block, s.texture, s.ratio, s.cap};
            if (!ob::block_match_supported(pair.left, pair.right, p)) {
              EXPECT_GE(block, std::min(pair.left.rows, pair.left.cols)) << pair.name;
              continue;
            }
            cv::Mat ours;
            ob::block_match(pair.left, pair.right, p, ours);
            if (disparities - 1 + block / 2 >= pair.left.cols - block / 2) {
              // No pixel's window has every disparity inside the image: none matched. (StereoBM
              // leaves its output unwritten then, unless the image is narrower than the range.)
              EXPECT_EQ(cv::countNonZero(ours != -16), 0) << pair.name;
              continue;
            }
            const cv::Mat expected = opencv_block_match(pair.left, pair.right, p);
            ASSERT_EQ(ours.type(), CV_16SC1);
            ASSERT_EQ(ours.size(), expected.size());
            EXPECT_EQ(differences(ours, expected), 0)
                << pair.name << ", " << disparities << " disparities, block " << block
                << ", texture " << s.texture << ", ratio " << s.ratio << ", cap " << s.cap << " on "
                << hwy::TargetName(target);
            matched_pixels += cv::countNonZero(expected > 0);
            ++compared;
          }
        }
      }
    }
  }
  EXPECT_GT(compared, 300);
  // The scenes are matched, not only refused: most settings give disparities.
  EXPECT_GT(matched_pixels, 100000);
}

// The dense stage's block matching (block_match and StereoBM's speckle filter; a block over 21 px:
// StereoBM itself, its speckle filter run after it) gives what cv::StereoBM gives with the same
// settings, speckle filter included.
TEST(BlockMatching, DenseDisparityEqualsOpenCvWithSpeckleFilter) {
  const Pair pair = scene(468, 138, 0, 7);
  for (const int block : {7, 23}) {
    ob::DenseOptions options;  // the stage's: uniqueness 12, speckles 40 px within 1 px
    options.block_size = block;
    const int threshold = ob::block_texture_threshold(pair.left, options);
    const cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(32, options.block_size);
    bm->setPreFilterCap(31);
    bm->setTextureThreshold(threshold);
    bm->setUniquenessRatio(options.uniqueness_ratio);
    bm->setSpeckleWindowSize(options.speckle_window);
    bm->setSpeckleRange(16 * options.speckle_range_px);
    cv::Mat fixed;
    bm->compute(pair.left, pair.right, fixed);
    const cv::Mat ours = ob::dense_disparity(pair.left, pair.right, 30.0, options);
    ASSERT_EQ(ours.size(), fixed.size());
    int valid = 0;
    for (int y = 0; y < fixed.rows; ++y) {
      for (int x = 0; x < fixed.cols; ++x) {
        const short f = fixed.at<short>(y, x);
        const float d = ours.at<float>(y, x);
        if (f > 0) {
          ++valid;
          ASSERT_EQ(d, static_cast<float>(f) / 16.f) << "block " << block << ": " << x << ", " << y;
        } else {
          ASSERT_TRUE(std::isnan(d)) << "block " << block << ": " << x << ", " << y;
        }
      }
    }
    EXPECT_GT(valid, fixed.rows * fixed.cols / 4) << "block " << block;
  }
}

TEST(BlockMatching, RefusesWhatItDoesNotCover) {
  const Pair pair = scene(128, 40, 0, 8);
  cv::Mat out;
  const ob::BlockMatchParams fine{32, 7, 0, 10, 31};
  EXPECT_TRUE(ob::block_match_supported(pair.left, pair.right, fine));
  for (const ob::BlockMatchParams& p :
       {ob::BlockMatchParams{24, 7, 0, 10, 31}, ob::BlockMatchParams{32, 8, 0, 10, 31},
        ob::BlockMatchParams{32, 23, 0, 10, 31}, ob::BlockMatchParams{32, 7, -1, 10, 31},
        ob::BlockMatchParams{32, 7, 0, 10, 63}, ob::BlockMatchParams{32, 41, 0, 10, 31}}) {
    EXPECT_FALSE(ob::block_match_supported(pair.left, pair.right, p));
    EXPECT_THROW(ob::block_match(pair.left, pair.right, p, out), std::invalid_argument);
  }
  EXPECT_FALSE(ob::block_match_supported(pair.left, pair.right(cv::Rect(0, 0, 100, 40)), fine));
  cv::Mat colour;
  cv::cvtColor(pair.left, colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(ob::block_match_supported(colour, colour, fine));
  // An image narrower than the disparities: no pixel has a match, as with StereoBM.
  const cv::Mat narrow_left = pair.left(cv::Rect(0, 0, 30, 40)).clone();
  const cv::Mat narrow_right = pair.right(cv::Rect(0, 0, 30, 40)).clone();
  ob::block_match(narrow_left, narrow_right, fine, out);
  EXPECT_EQ(cv::countNonZero(out != -16), 0);
  EXPECT_EQ(differences(out, opencv_block_match(narrow_left, narrow_right, fine)), 0);
}

}  // namespace
