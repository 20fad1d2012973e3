// `thermovis obstacles` on the MS2 road frame (../shared/data/stereo/ms2_sample/000011: a
// day-time urban road, a van ahead, a car parked on the left, poles, trees and hedges; rectified
// RGB and LWIR pairs with their calibration, SOURCES.md; no ground-truth depth). The two pairs
// are independent measurements of one scene: each must find the ground, and the van ahead must
// be an obstacle at about one distance in both.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "thermovis/test/data.hpp"

using thermovis::test::run_thermovis;

namespace {

struct Box {
  int x0, y0, x1, y1;
};

// The nearest obstacle whose box overlaps `region` (pixels of the left image) by a third of its
// own area.
std::optional<double> nearest_in(const nlohmann::json& result, Box region) {
  std::optional<double> best;
  for (const auto& o : result.at("obstacles")) {
    const auto& b = o.at("box");
    const int x0 = b[0], y0 = b[1], x1 = b[2], y1 = b[3];
    const int w = std::min(x1, region.x1) - std::max(x0, region.x0);
    const int h = std::min(y1, region.y1) - std::max(y0, region.y0);
    if (w <= 0 || h <= 0 || 3 * w * h < (x1 - x0) * (y1 - y0)) continue;
    const double d = o.at("distance_m");
    if (!best || d < *best) best = d;
  }
  return best;
}

// The pair `modality` ("rgb", "thr") of the MS2 frame with its calibration (calib_ms2.txt).
std::string pair_args(const std::filesystem::path& frame, const std::string& modality) {
  const std::string left = (frame / "left" / (modality + ".png")).string();
  const std::string right = (frame / "right" / (modality + ".png")).string();
  const std::string calib = modality == "rgb" ? "--fx 764.513871 --cx 579.547012 --cy 153.005413 "
                                                "--baseline-m 0.299184"
                                              : "--fx 387.786951 --cx 300.820137 --cy 151.625763 "
                                                "--baseline-m 0.3039";
  return "obstacles --left " + left + " --right " + right + " " + calib;
}

nlohmann::json run_json(const std::string& args) {
  const auto r = run_thermovis(args + " --json");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  if (r.exit_code != 0) return nlohmann::json::object({{"obstacles", nlohmann::json::array()}});
  return nlohmann::json::parse(
      r.output.substr(r.output.rfind("\n{") == std::string::npos ? 0 : r.output.rfind("\n{") + 1));
}

}  // namespace

// Measured: the RGB pair's ground 2.08 m below the camera, pitch 1.0 deg; the van 23.9-24.4 m;
// the parked car 11.1 m. The LWIR pair's ground 1.91 m below, pitch 8.8 deg (that camera looks
// further down); the van 20.5 m. MS2's mounting is not given: the heights are checked against
// a roof-mounted rig's 1.5-2.4 m. The ground fit's default inlier share (0.2) is what lets both
// pairs find their ground here (0.4, as it was, finds none). Both need the inlier share lowered
// from the simulated road's 0.4 to 0.2: hedges, trees and cars fill much of the real image's lower
// half.
TEST(ObstaclesCli, TheRealRoadsGroundAndTheVanAheadInBothBands) {
  const auto frame = thermovis::test::data_path("stereo/ms2_sample/000011");
  if (frame.empty()) GTEST_SKIP() << "no MS2 sample in the test data";

  const nlohmann::json rgb =
      run_json(pair_args(frame, "rgb") + " --camera-height-m 1.8 --pitch-deg -3");
  ASSERT_EQ(rgb.value("ground", ""), "ok") << rgb.dump();
  EXPECT_EQ(rgb.at("band"), "visible");
  EXPECT_GT(rgb.at("ground_height_m").get<double>(), 1.5);
  EXPECT_LT(rgb.at("ground_height_m").get<double>(), 2.4);
  const auto van_rgb = nearest_in(rgb, {465, 165, 560, 255});
  ASSERT_TRUE(van_rgb) << rgb.dump();
  EXPECT_GT(*van_rgb, 18.0);
  EXPECT_LT(*van_rgb, 32.0);
  const auto car_rgb = nearest_in(rgb, {0, 170, 150, 300});
  ASSERT_TRUE(car_rgb) << rgb.dump();
  EXPECT_LT(*car_rgb, 15.0);

  const nlohmann::json thr =
      run_json(pair_args(frame, "thr") + " --camera-height-m 1.8 --pitch-deg 5");
  ASSERT_EQ(thr.value("ground", ""), "ok") << thr.dump();
  EXPECT_EQ(thr.at("band"), "infrared");
  EXPECT_GT(thr.at("ground_pitch_deg").get<double>(), 4.0);
  const auto van_thr = nearest_in(thr, {240, 95, 295, 150});
  ASSERT_TRUE(van_thr) << thr.dump();
  // Two cameras about half a metre apart measuring the same van.
  EXPECT_NEAR(*van_thr, *van_rgb, 5.0);
}

// A prior far from the rig's pitch (12 deg up), or the ground asked to hold 40 % of the
// disparities: no ground, so a status and no obstacle.
TEST(ObstaclesCli, NoGroundIsAStatusNotObstacles) {
  const auto frame = thermovis::test::data_path("stereo/ms2_sample/000011");
  if (frame.empty()) GTEST_SKIP() << "no MS2 sample in the test data";
  for (const char* prior : {" --pitch-deg -12", " --pitch-deg -3 --min-inlier-share 0.4"}) {
    const nlohmann::json rgb = run_json(pair_args(frame, "rgb") + prior);
    EXPECT_EQ(rgb.value("ground", ""), "no_ground") << prior << ": " << rgb.dump();
    EXPECT_TRUE(rgb.at("obstacles").empty()) << prior;
  }
}

TEST(ObstaclesCli, AMissingImageOrAMismatchedPairIsAClearError) {
  const auto frame = thermovis::test::data_path("stereo/ms2_sample/000011");
  if (frame.empty()) GTEST_SKIP() << "no MS2 sample in the test data";
  const auto missing = run_thermovis(
      "obstacles --left /nonexistent.png --right /nonexistent.png --fx 100 --cx 10 --cy 10 "
      "--baseline-m 0.3");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("/nonexistent.png"), std::string::npos) << missing.output;
  const auto mixed = run_thermovis("obstacles --left " + (frame / "left/rgb.png").string() +
                                   " --right " + (frame / "right/thr.png").string() +
                                   " --fx 100 --cx 10 --cy 10 --baseline-m 0.3");
  EXPECT_NE(mixed.exit_code, 0);
  EXPECT_NE(mixed.output.find("differ"), std::string::npos) << mixed.output;
}
