// Visible contrast enhancement (CLAHE on luma): dark and bright regions gain contrast, colour
// is kept, bad input is rejected.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/enhance/visible_contrast.hpp"

namespace {

namespace en = thermovis::enhance;

double local_contrast(const cv::Mat& gray) {
  cv::Scalar mean, sd;
  cv::meanStdDev(gray, mean, sd);
  return sd[0];
}

// Left half dark (10..40), right half bright (210..245), each with texture.
cv::Mat dark_and_bright() {
  cv::Mat img(240, 320, CV_8UC3);
  cv::RNG rng(7);
  for (int r = 0; r < img.rows; ++r) {
    for (int c = 0; c < img.cols; ++c) {
      const int texture = ((r / 8 + c / 8) % 2) * 20 + rng.uniform(0, 10);
      const int y = c < 160 ? 10 + texture : 210 + texture;
      img.at<cv::Vec3b>(r, c) =
          cv::Vec3b(cv::saturate_cast<uchar>(y - 5), cv::saturate_cast<uchar>(y),
                    cv::saturate_cast<uchar>(y + 5));
    }
  }
  return img;
}

TEST(VisibleContrast, DarkAndBrightRegionsGainContrast) {
  const cv::Mat img = dark_and_bright();
  const cv::Mat out = en::enhance_visible(img);
  ASSERT_EQ(out.type(), CV_8UC3);
  cv::Mat g_in, g_out;
  cv::cvtColor(img, g_in, cv::COLOR_BGR2GRAY);
  cv::cvtColor(out, g_out, cv::COLOR_BGR2GRAY);
  for (const cv::Rect half : {cv::Rect(16, 16, 128, 208), cv::Rect(176, 16, 128, 208)}) {
    EXPECT_GT(local_contrast(g_out(half)), 1.5 * local_contrast(g_in(half)));
  }
}

TEST(VisibleContrast, GrayInputAndBadInput) {
  cv::Mat gray;
  cv::cvtColor(dark_and_bright(), gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(en::enhance_visible(gray).type(), CV_8UC1);
  EXPECT_THROW(en::enhance_visible(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(en::enhance_visible(cv::Mat(8, 8, CV_16UC1)), std::invalid_argument);
  EXPECT_THROW(en::enhance_visible(gray, {0.0, 8, 8}), std::invalid_argument);
}

}  // namespace
