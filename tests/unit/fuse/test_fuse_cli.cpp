// `thermovis fuse` and `fuse-eval` with raw 14/16-bit infrared, as a thermal camera and
// `thermovis scene render` give it: the counts go through the pipeline's gain control (the
// default InfraredAgc) before fusion, so the output is what fusing the AGC's 8-bit image gives.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/fuse/fusion.hpp"
#include "thermovis/test/data.hpp"

namespace {

namespace fs = std::filesystem;
using thermovis::test::run_thermovis;

// A warm square on a cooler ramp, in 14-bit counts, and a visible image of the same size.
void write_pair(const fs::path& ir, const fs::path& vis) {
  cv::Mat counts(96, 128, CV_16UC1);
  for (int y = 0; y < counts.rows; ++y)
    for (int x = 0; x < counts.cols; ++x)
      counts.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(7000 + 20 * x + 5 * y);
  counts(cv::Rect(40, 30, 24, 24)).setTo(12000);
  cv::Mat colour(96, 128, CV_8UC3);
  cv::randu(colour, 0, 256);
  ASSERT_TRUE(cv::imwrite(ir.string(), counts));
  ASSERT_TRUE(cv::imwrite(vis.string(), colour));
}

TEST(FuseCli, RawInfraredGoesThroughThePipelinesGainControl) {
  const fs::path dir = thermovis::test::temp_dir("fuse_cli_raw");
  write_pair(dir / "ir.png", dir / "vis.png");
  const auto r = run_thermovis("fuse --ir " + (dir / "ir.png").string() + " --vis " +
                               (dir / "vis.png").string() + " --out " +
                               (dir / "fused.png").string() + " --method fast");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const cv::Mat fused = cv::imread((dir / "fused.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(fused.type(), CV_8UC3);

  const cv::Mat counts = cv::imread((dir / "ir.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(counts.type(), CV_16UC1);
  thermovis::fuse::FusionOptions options;
  options.method = thermovis::fuse::FusionMethod::fast;
  const cv::Mat expected =
      thermovis::fuse::fuse(thermovis::enhance::InfraredAgc().process(counts),
                            cv::imread((dir / "vis.png").string(), cv::IMREAD_UNCHANGED), options);
  EXPECT_EQ(cv::norm(fused, expected, cv::NORM_INF), 0.0);
}

TEST(FuseCli, FuseEvalTakesRawInfrared) {
  const fs::path dir = thermovis::test::temp_dir("fuse_eval_raw");
  fs::create_directories(dir / "IR");
  fs::create_directories(dir / "VI");
  write_pair(dir / "IR/a.png", dir / "VI/a.png");
  const auto r = run_thermovis("fuse-eval --dir " + dir.string() + " --method fast --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto line = r.output.substr(r.output.find('{'));
  const auto j = nlohmann::json::parse(line.substr(0, line.find('\n')));
  EXPECT_EQ(j["pairs"], 1);
  EXPECT_GT(j["mean"]["EN"].get<double>(), 0.0) << j;
}

}  // namespace
