// The fusion-ranging image: the frame stamp survives JPEG and is read back exactly, the image
// has the header and the boxes where the targets are, and bad input is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/display/frame_stamp.hpp"
#include "thermovis/display/ranging_image.hpp"

namespace {

namespace display = thermovis::display;

cv::Mat noisy_image(cv::Size size, int type, unsigned seed) {
  cv::Mat image(size, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.5);
  return image;
}

TEST(FrameStamp, SurvivesJpegAtUsualQualities) {
  std::mt19937_64 random(7);
  for (const int quality : {40, 60, 80, 95}) {
    for (int trial = 0; trial < 20; ++trial) {
      cv::Mat image = noisy_image({640, 360}, CV_8UC3, static_cast<unsigned>(trial));
      const std::uint64_t seq = random() % 1'000'000;
      // Around now, at any sub-millisecond offset.
      const std::int64_t capture =
          1'795'000'000'000'000'000 + static_cast<std::int64_t>(random() % 10'000'000'000'000ULL);
      display::draw_stamp(image, seq, capture);
      std::vector<unsigned char> jpeg;
      cv::imencode(".jpg", image, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
      const auto stamp = display::read_stamp(cv::imdecode(jpeg, cv::IMREAD_COLOR));
      ASSERT_TRUE(stamp.has_value()) << "quality " << quality << " trial " << trial;
      EXPECT_EQ(stamp->seq_mod_256, seq % 256);
      EXPECT_EQ(stamp->capture_time_ns, capture / display::kStampUnitNs * display::kStampUnitNs);
    }
  }
}

TEST(FrameStamp, IsNotFoundInImagesWithoutOne) {
  int found = 0;
  for (unsigned seed = 0; seed < 200; ++seed) {
    found += display::read_stamp(noisy_image({640, 64}, CV_8UC3, seed)).has_value();
  }
  EXPECT_LE(found, 3);  // the 8-bit checksum lets about 1 in 256 random corners through
  EXPECT_FALSE(display::read_stamp(cv::Mat(64, 640, CV_8UC3, cv::Scalar::all(0))).has_value());
  EXPECT_FALSE(display::read_stamp(cv::Mat(4, 640, CV_8UC3)).has_value());
  cv::Mat narrow(64, 100, CV_8UC3);
  EXPECT_THROW(display::draw_stamp(narrow, 1, 1), std::invalid_argument);
}

TEST(RangingImage, FramesEachTargetBelowTheHeaderWithItsStamp) {
  const cv::Mat fused(540, 932, CV_8UC3, cv::Scalar(40, 40, 40));
  display::Target ranged;
  ranged.id = 3;
  ranged.label = "person";
  ranged.box = {400.f, 200.f, 30.f, 90.f};
  ranged.distance_m = 10.04;
  ranged.sigma_m = 0.03;
  ranged.band = display::kBandVisible;
  display::Target detected = ranged;
  detected.id = 4;
  detected.box = {100.f, 300.f, 20.f, 50.f};
  detected.distance_m = std::nan("");
  display::Status status;
  status.frame_seq = 342;
  status.capture_time_ns = 1'795'000'000'123'400'000;
  status.latency_ms = 31.2;

  const cv::Mat out = display::compose(fused, {ranged, detected}, status);
  ASSERT_EQ(out.type(), CV_8UC3);
  ASSERT_EQ(out.rows, fused.rows + display::kHeaderRows);
  ASSERT_EQ(out.cols, fused.cols);
  const auto stamp = display::read_stamp(out);
  ASSERT_TRUE(stamp.has_value());
  EXPECT_EQ(stamp->capture_time_ns, status.capture_time_ns);
  EXPECT_EQ(stamp->seq_mod_256, 342 % 256);
  // The boxes' edges are drawn (band colour for the ranged target, grey for the other) and
  // their inside is the image.
  const int y0 = display::kHeaderRows;
  const cv::Vec3b edge = out.at<cv::Vec3b>(y0 + 245, 400);
  EXPECT_GT(edge[1], 150);  // yellow: green and red high, blue low
  EXPECT_GT(edge[2], 150);
  EXPECT_LT(edge[0], 100);
  const cv::Vec3b grey = out.at<cv::Vec3b>(y0 + 325, 100);
  EXPECT_NEAR(grey[0], 160, 40);
  EXPECT_NEAR(grey[1], grey[0], 10);
  EXPECT_EQ(out.at<cv::Vec3b>(y0 + 250, 415), cv::Vec3b(40, 40, 40));
  EXPECT_EQ(display::target_caption(ranged), "#3 10.04 +- 0.03 m VIS");
  EXPECT_EQ(display::target_caption(detected), "#4 no range");
  detected.label = "vehicle";
  EXPECT_EQ(display::target_caption(detected), "vehicle #4 no range");
}

TEST(RangingImage, SideBySideHoldsThreeScaledPanels) {
  const cv::Mat visible(540, 932, CV_8UC3, cv::Scalar(0, 0, 200));
  const cv::Mat infrared(540, 932, CV_8UC1, cv::Scalar(128));
  const cv::Mat fused(540, 932, CV_8UC3, cv::Scalar(0, 200, 0));
  display::Status status;
  status.capture_time_ns = 1'795'000'000'000'000'000;
  const cv::Mat out = display::compose_side_by_side(visible, infrared, fused, {}, status, 0.5);
  EXPECT_EQ(out.cols, 3 * 466);
  EXPECT_EQ(out.rows, 270 + display::kHeaderRows);
  EXPECT_EQ(out.at<cv::Vec3b>(100, 100), cv::Vec3b(0, 0, 200));
  EXPECT_EQ(out.at<cv::Vec3b>(100, 466 + 100), cv::Vec3b(128, 128, 128));
  EXPECT_EQ(out.at<cv::Vec3b>(100, 2 * 466 + 100), cv::Vec3b(0, 200, 0));
  EXPECT_TRUE(display::read_stamp(out).has_value());
  EXPECT_THROW(display::compose_side_by_side(visible, cv::Mat(10, 10, CV_8UC1), fused, {}, status),
               std::invalid_argument);
  EXPECT_THROW(display::compose(cv::Mat(), {}, status), std::invalid_argument);
  EXPECT_THROW(display::compose(cv::Mat(10, 10, CV_16UC1), {}, status), std::invalid_argument);
}

TEST(RangingImage, ViewNamesRoundTrip) {
  for (auto v : {display::View::fused, display::View::visible, display::View::infrared,
                 display::View::side_by_side}) {
    EXPECT_EQ(display::parse_view(display::to_string(v)), v);
  }
  EXPECT_FALSE(display::parse_view("thermal").has_value());
}

}  // namespace
