// Infrared AGC: plateau equalisation of raw counts, its plateau, its temporal smoothing, bad input.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "thermovis/enhance/infrared_agc.hpp"

namespace {

namespace en = thermovis::enhance;

// 90 % of the frame a uniform background at `background` counts, the rest a horizontal ramp
// object from lo to hi counts (16-bit raw, as a 14-bit detector delivers).
cv::Mat scene(int background, int lo, int hi) {
  cv::Mat raw(200, 400, CV_16UC1, cv::Scalar(background));
  for (int r = 180; r < 200; ++r) {
    for (int c = 0; c < 400; ++c)
      raw.at<std::uint16_t>(r, c) = static_cast<std::uint16_t>(lo + (hi - lo) * c / 399);
  }
  return raw;
}

double object_range(const cv::Mat& out) {
  double lo = 0, hi = 0;
  cv::minMaxLoc(out.rowRange(180, 200), &lo, &hi);
  return hi - lo;
}

TEST(InfraredAgc, MapsRawCountsMonotonicallyOverTheFullRange) {
  cv::Mat raw(64, 1024, CV_16UC1);
  for (int c = 0; c < 1024; ++c) raw.col(c).setTo(cv::Scalar(6000 + 4 * c));  // 14-bit counts
  const cv::Mat out = en::InfraredAgc({2.0, 0.0, 1.0}).process(raw);
  ASSERT_EQ(out.type(), CV_8UC1);
  for (int c = 1; c < 1024; ++c) EXPECT_GE(out.at<uchar>(0, c), out.at<uchar>(0, c - 1));
  EXPECT_LE(out.at<uchar>(0, 0), 1);
  EXPECT_GE(out.at<uchar>(0, 1023), 254);
}

// The plateau keeps a large uniform background from taking the grey levels of a small object:
// plain equalisation (huge plateau) leaves the object about 10 % of the range.
TEST(InfraredAgc, PlateauGivesSmallObjectsTheirContrast) {
  const cv::Mat raw = scene(8000, 8100, 8300);
  const double plain = object_range(en::InfraredAgc({1e9, 0.0, 1.0}).process(raw));
  const double plateau = object_range(en::InfraredAgc({1.0, 0.0, 1.0}).process(raw));
  EXPECT_LT(plain, 30.0);
  EXPECT_GT(plateau, 200.0);
}

// A hot object entering the view changes the mapping; smoothing spreads the change over frames
// (first step about temporal_alpha of it) and converges to the new frame's own mapping.
TEST(InfraredAgc, TemporalSmoothingDampsAndConverges) {
  const cv::Mat before = scene(8000, 8100, 8300);
  cv::Mat after = before.clone();
  for (int c = 0; c < 400; ++c) {  // hot object over 30 % of the frame, 10000..14000 counts
    after(cv::Rect(c, 0, 1, 60)).setTo(cv::Scalar(10000 + 10 * c));
  }
  const cv::Rect object(0, 180, 400, 20);
  const auto object_mean = [&](const cv::Mat& out) { return cv::mean(out(object))[0]; };

  en::InfraredAgc instant({2.0, 0.0, 1.0});
  const double jump = object_mean(instant.process(after)) - object_mean(instant.process(before));
  en::InfraredAgc smoothed({2.0, 0.0, 0.2});
  const double first = object_mean(smoothed.process(before));
  const double step = object_mean(smoothed.process(after)) - first;
  ASSERT_GT(std::abs(jump), 20.0);
  EXPECT_NEAR(step / jump, 0.2, 0.05);
  cv::Mat settled;
  for (int i = 0; i < 40; ++i) settled = smoothed.process(after);
  cv::Mat diff;
  cv::absdiff(settled, en::InfraredAgc({2.0, 0.0, 1.0}).process(after), diff);
  double max_diff = 0;
  cv::minMaxLoc(diff, nullptr, &max_diff);
  EXPECT_LE(max_diff, 1.0);
}

TEST(InfraredAgc, EightBitInputTakesTheSamePath) {
  cv::Mat raw(32, 256, CV_8UC1);
  for (int c = 0; c < 256; ++c)
    raw.col(c).setTo(cv::Scalar(c / 4 + 100));  // 64 levels, low contrast
  const cv::Mat out = en::InfraredAgc({2.0, 0.0, 1.0}).process(raw);
  double lo = 0, hi = 0;
  cv::minMaxLoc(out, &lo, &hi);
  EXPECT_LE(lo, 3.0);
  EXPECT_GE(hi, 252.0);
}

TEST(InfraredAgc, BadInputIsRejected) {
  en::InfraredAgc agc;
  EXPECT_THROW(agc.process(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(agc.process(cv::Mat(8, 8, CV_32FC1, cv::Scalar(0.5))), std::invalid_argument);
  EXPECT_THROW(agc.process(cv::Mat(8, 8, CV_16UC3)), std::invalid_argument);
  EXPECT_THROW(en::InfraredAgc({0.0, 0.0, 0.5}), std::invalid_argument);
  EXPECT_THROW(en::InfraredAgc({2.0, 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(en::InfraredAgc({2.0, 0.7, 0.5}), std::invalid_argument);
}

}  // namespace
