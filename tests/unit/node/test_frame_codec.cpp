// Frame <-> cv::Mat views: zero-copy, and clear errors for impossible frame headers.
#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <opencv2/core.hpp>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"

namespace tn = thermovis::node;

namespace {

TEST(FrameCodec, PreparedViewsWriteIntoTheFrameWithoutCopy) {
  auto frame = std::make_unique<thermovis::InfraredStereoFrame>();
  cv::Mat left = tn::prepare(*frame, tn::Eye::left, {1024, 768});
  cv::Mat right = tn::prepare(*frame, tn::Eye::right, {1024, 768});
  left.setTo(1234);
  right.at<std::uint16_t>(767, 1023) = 16383;
  EXPECT_EQ(frame->left()[0], 1234);
  EXPECT_EQ(frame->right()[767 * 1024 + 1023], 16383);
  const cv::Mat seen = tn::view(*frame, tn::Eye::left);
  EXPECT_EQ(seen.data, reinterpret_cast<const uchar*>(frame->left().data()));
  EXPECT_EQ(seen.type(), CV_16UC1);
  EXPECT_EQ(frame->pixel_format(), thermovis::PIXEL_FORMAT_MONO16);
}

TEST(FrameCodec, GridFramesCarryTheirPixelFormat) {
  auto frame = std::make_unique<thermovis::GridStereoFrame>();
  cv::Mat mono = tn::prepare(*frame, tn::Eye::right, {640, 400}, CV_8UC1);
  EXPECT_EQ(tn::view(*frame, tn::Eye::right).type(), CV_8UC1);
  const cv::Size full(thermovis::GRID_WIDTH, thermovis::GRID_HEIGHT);
  cv::Mat colour = tn::prepare(*frame, tn::Eye::left, full, CV_8UC3);
  EXPECT_EQ(tn::view(*frame, tn::Eye::left).size(), full);
  // Rows are packed: a frame is valid while its bytes fit the array, whatever the shape.
  EXPECT_THROW(tn::prepare(*frame, tn::Eye::left, full + cv::Size(0, 1), CV_8UC3), tn::FrameError);
  EXPECT_THROW(tn::prepare(*frame, tn::Eye::left, {64, 64}, CV_32FC1), tn::FrameError);
}

TEST(FrameCodec, ImpossibleHeadersAreNamed) {
  auto frame = std::make_unique<thermovis::VisibleStereoFrame>();
  frame->seq(77);
  frame->pixel_format(thermovis::PIXEL_FORMAT_BGR8);
  frame->width(4000);
  frame->height(1080);
  try {
    tn::view(*frame, tn::Eye::left);
    FAIL() << "oversized frame accepted";
  } catch (const tn::FrameError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("frame 77"), std::string::npos) << what;
    EXPECT_NE(what.find("4000x1080"), std::string::npos) << what;
  }
  frame->width(0);
  EXPECT_THROW(tn::view(*frame, tn::Eye::left), tn::FrameError);
  frame->width(1920);
  frame->pixel_format(thermovis::PIXEL_FORMAT_MONO16);  // visible frames are BGR8
  EXPECT_THROW(tn::view(*frame, tn::Eye::left), tn::FrameError);
  frame->pixel_format(99);
  EXPECT_THROW(tn::view(*frame, tn::Eye::left), tn::FrameError);
}

TEST(Boxes, RoundOutwardsAndRejectNonFiniteFields) {
  thermovis::Box2D box;
  box.x(10.5f);
  box.y(20.2f);
  box.width(5.0f);
  box.height(4.5f);
  EXPECT_EQ(tn::to_rect(box), cv::Rect(10, 20, 6, 5));
  EXPECT_EQ(tn::to_rect(tn::to_box(cv::Rect(3, 4, 5, 6))), cv::Rect(3, 4, 5, 6));
  box.width(std::numeric_limits<float>::quiet_NaN());
  EXPECT_TRUE(tn::to_rect(box).empty());
  box.width(-3.0f);
  EXPECT_TRUE(tn::to_rect(box).empty());
}

}  // namespace
