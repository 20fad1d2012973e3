// The shift bound against the spread of an efficient estimate: a smooth pattern shifted by a
// known fraction of a pixel, noise in one eye (the other the noise-free template), the shift
// found by Gauss-Newton on the true pattern: its spread over many noise draws is the bound.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <stdexcept>

#include "thermovis/match/shift_bound.hpp"

namespace {

double pattern(double x, double y) {
  return 120.0 + 40.0 * std::sin(2 * M_PI * x / 23.0) + 25.0 * std::cos(2 * M_PI * (x + y) / 31.0);
}
double pattern_dx(double x, double y) {
  return 40.0 * 2 * M_PI / 23.0 * std::cos(2 * M_PI * x / 23.0) -
         25.0 * 2 * M_PI / 31.0 * std::sin(2 * M_PI * (x + y) / 31.0);
}

}  // namespace

TEST(ShiftBound, IsTheSpreadOfAnEfficientEstimate) {
  const cv::Size size(64, 16);
  cv::Mat clean(size, CV_32FC1);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) clean.at<float>(y, x) = float(pattern(x, y));
  const cv::Mat mask(size, CV_8UC1, cv::Scalar(1));
  const double sigma = 3.0, shift = 0.37;
  const double bound = thermovis::match::shift_bound_px(clean, mask, sigma * sigma);
  ASSERT_TRUE(std::isfinite(bound));
  std::mt19937 random(3);
  std::normal_distribution<double> noise(0.0, sigma);
  double sum = 0, sum2 = 0;
  const int draws = 400;
  for (int n = 0; n < draws; ++n) {
    cv::Mat right(size, CV_32FC1);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        right.at<float>(y, x) = float(pattern(x - shift, y) + noise(random));
    double d = 0;
    for (int it = 0; it < 6; ++it) {  // min over d of sum (T(x - d) - R)^2
      double num = 0, den = 0;
      for (int y = 0; y < size.height; ++y) {
        for (int x = 1; x + 1 < size.width; ++x) {
          const double r = pattern(x - d, y) - right.at<float>(y, x);
          const double j = -pattern_dx(x - d, y);
          num += j * r;
          den += j * j;
        }
      }
      d -= num / den;
    }
    sum += d;
    sum2 += d * d;
  }
  const double mean = sum / draws, spread = std::sqrt(sum2 / draws - mean * mean);
  EXPECT_NEAR(mean, shift, 4 * spread / std::sqrt(double(draws)));
  // The sampled spread of 400 draws is within 10 % of the true one (3.5 of its sigmas); the
  // central difference reads the pattern's slope 1 % low.
  EXPECT_NEAR(spread, bound, 0.1 * bound) << "bound " << bound << " px";
  // Both eyes noisy: twice the variance.
  EXPECT_NEAR(thermovis::match::shift_bound_px(clean, mask, 2 * sigma * sigma),
              std::sqrt(2.0) * bound, 1e-12);
}

TEST(ShiftBound, ARegionWithoutGradientHasNoBoundAndBadInputIsNamed) {
  const cv::Mat flat(8, 8, CV_8UC1, cv::Scalar(90));
  const cv::Mat mask(8, 8, CV_8UC1, cv::Scalar(1));
  EXPECT_EQ(thermovis::match::shift_bound_px(flat, mask, 4.0),
            std::numeric_limits<double>::infinity());
  // Only the masked pixels count: a step outside the mask leaves it without gradient.
  cv::Mat step = flat.clone();
  step.colRange(6, 8).setTo(200);
  cv::Mat left_half(8, 8, CV_8UC1, cv::Scalar(0));
  left_half.colRange(0, 4).setTo(1);
  EXPECT_EQ(thermovis::match::shift_bound_px(step, left_half, 4.0),
            std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isfinite(thermovis::match::shift_bound_px(step, mask, 4.0)));
  EXPECT_THROW(thermovis::match::shift_bound_px(flat, cv::Mat(4, 4, CV_8UC1), 1.0),
               std::invalid_argument);
  EXPECT_THROW(thermovis::match::shift_bound_px(cv::Mat(8, 8, CV_64FC1), mask, 1.0),
               std::invalid_argument);
  EXPECT_THROW(thermovis::match::shift_bound_px(flat, mask, -1.0), std::invalid_argument);
  EXPECT_THROW(thermovis::match::shift_bound_px(flat, mask, std::nan("")), std::invalid_argument);
}
