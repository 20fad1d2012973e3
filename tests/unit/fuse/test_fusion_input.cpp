// Bad input to the fusion entry point: a clear std::invalid_argument, never a crash.
#include <gtest/gtest.h>

#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fuse/fusion.hpp"

namespace {

namespace fu = thermovis::fuse;

fu::FusionOptions with(fu::FusionMethod method,
                       fu::ColourMode colour = fu::ColourMode::per_channel) {
  fu::FusionOptions o;
  o.method = method;
  o.colour = colour;
  return o;
}

std::string message_of(const cv::Mat& ir, const cv::Mat& vis, fu::FusionMethod method) {
  try {
    fu::fuse(ir, vis, with(method));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

class FusionBadInput : public ::testing::TestWithParam<fu::FusionMethod> {};

TEST_P(FusionBadInput, RejectedWithAMessageNamingTheProblem) {
  const auto method = GetParam();
  const cv::Mat ir(48, 64, CV_8UC1, cv::Scalar(100));
  const cv::Mat vis(48, 64, CV_8UC3, cv::Scalar(20, 40, 60));
  EXPECT_NE(message_of(ir, cv::Mat(40, 64, CV_8UC3), method).find("size"), std::string::npos);
  EXPECT_NE(message_of(cv::Mat(), vis, method).find("empty"), std::string::npos);
  EXPECT_NE(message_of(ir, cv::Mat(48, 64, CV_16UC3), method).find("8-bit or float"),
            std::string::npos);
  EXPECT_NE(
      message_of(ir, cv::Mat(48, 64, CV_32FC3, cv::Scalar::all(0.5)), method).find("pixel type"),
      std::string::npos);
  cv::Mat ir_nan(48, 64, CV_32FC1, cv::Scalar(0.5));
  cv::Mat vis_f(48, 64, CV_32FC1, cv::Scalar(0.5));
  ir_nan.at<float>(3, 5) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(message_of(ir_nan, vis_f, method).find("NaN"), std::string::npos);
  ir_nan.at<float>(3, 5) = std::numeric_limits<float>::infinity();
  EXPECT_NE(message_of(ir_nan, vis_f, method).find("NaN or infinite"), std::string::npos);
  EXPECT_NE(message_of(cv::Mat(10, 10, CV_8UC1), cv::Mat(10, 10, CV_8UC1), method).find("18x18"),
            std::string::npos);
  // Valid float input is accepted and gives an 8-bit result of the visible channel count.
  const cv::Mat out = fu::fuse(cv::Mat(48, 64, CV_32FC1, cv::Scalar(0.25)), vis_f, with(method));
  EXPECT_EQ(out.type(), CV_8UC1);
}

INSTANTIATE_TEST_SUITE_P(AllMethods, FusionBadInput,
                         ::testing::Values(fu::FusionMethod::vsmwls, fu::FusionMethod::vsmwls_paper,
                                           fu::FusionMethod::fast));

// Equal inputs fuse to themselves (all weights sum to one, detail layers add up to the input).
TEST(Fusion, EqualInputsReproduceTheInput) {
  cv::Mat img(60, 80, CV_8UC1);
  cv::randu(img, 30, 220);
  for (auto method : {fu::FusionMethod::vsmwls, fu::FusionMethod::fast}) {
    const cv::Mat out = fu::fuse(img, img, with(method));
    cv::Mat diff;
    cv::absdiff(out, img, diff);
    double max_diff = 0;
    cv::minMaxLoc(diff, nullptr, &max_diff);
    EXPECT_LE(max_diff, 1.0) << fu::method_name(method);
  }
}

// Luminance mode keeps the visible chroma: BT.601 Cb/Cr of the result equal the visible's
// where no channel saturates.
TEST(Fusion, LuminanceModeKeepsVisibleChroma) {
  cv::Mat vis(64, 64, CV_8UC3), ir(64, 64, CV_8UC1);
  cv::randu(vis, 60, 180);
  cv::randu(ir, 0, 255);
  for (auto method : {fu::FusionMethod::vsmwls, fu::FusionMethod::fast}) {
    const cv::Mat out = fu::fuse(ir, vis, with(method, fu::ColourMode::luminance));
    cv::Mat a, b;
    cv::Mat out_f, vis_f;
    out.convertTo(out_f, CV_32F);
    vis.convertTo(vis_f, CV_32F);
    cv::cvtColor(out_f, a, cv::COLOR_BGR2YCrCb);
    cv::cvtColor(vis_f, b, cv::COLOR_BGR2YCrCb);
    int checked = 0;
    for (int r = 0; r < 64; ++r) {
      for (int c = 0; c < 64; ++c) {
        const auto px = out.at<cv::Vec3b>(r, c);
        if (px[0] == 0 || px[1] == 0 || px[2] == 0 || px[0] == 255 || px[1] == 255 || px[2] == 255)
          continue;
        ++checked;
        EXPECT_NEAR(a.at<cv::Vec3f>(r, c)[1], b.at<cv::Vec3f>(r, c)[1], 1e-3);
        EXPECT_NEAR(a.at<cv::Vec3f>(r, c)[2], b.at<cv::Vec3f>(r, c)[2], 1e-3);
      }
    }
    EXPECT_GT(checked, 1000);
  }
}

// Enhancement inside the fusion (the pipeline's single luma pass) gives what enhancing the
// visible image first and fusing it gives, up to the rounding of the intermediate colour image.
TEST(Fusion, EnhancementOnTheFusedLumaEqualsEnhancingFirst) {
  cv::Mat vis(120, 160, CV_8UC3), ir(120, 160, CV_8UC1);
  cv::Mat dark(120, 160, CV_8UC1);
  cv::randu(dark, 20, 70);  // a dim scene: CLAHE changes it a lot
  cv::GaussianBlur(dark, dark, cv::Size(5, 5), 1.5);
  cv::merge(std::vector<cv::Mat>{dark, dark + 10, dark + 5}, vis);
  cv::randu(ir, 0, 255);
  cv::GaussianBlur(ir, ir, cv::Size(9, 9), 3.0);
  fu::FusionOptions plain = with(fu::FusionMethod::fast, fu::ColourMode::luminance);
  fu::FusionOptions inside = plain;
  inside.enhance_visible = thermovis::enhance::VisibleContrastParams{};
  const cv::Mat expected = fu::fuse(ir, thermovis::enhance::enhance_visible(vis), plain);
  const cv::Mat got = fu::fuse(ir, vis, inside);
  cv::Mat diff;
  cv::absdiff(expected, got, diff);
  double max_diff = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &max_diff);
  EXPECT_LE(max_diff, 3.0);
  EXPECT_LE(cv::mean(diff)[0], 0.6);
  // And it did enhance: the result differs from the unenhanced fusion.
  cv::Mat change;
  cv::absdiff(fu::fuse(ir, vis, plain), got, change);
  EXPECT_GT(cv::mean(change)[0], 5.0);
}

}  // namespace
