// `thermovis detect-eval --scene`: detection on simulated captures rectified onto the pipeline
// grid, against the simulator's people, as a user runs it (the built executable).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "thermovis/test/data.hpp"

using thermovis::test::run_thermovis;

namespace {

nlohmann::json last_json_line(const std::string& output) {
  const auto start = output.rfind("\n{");
  return nlohmann::json::parse(output.substr(start == std::string::npos ? 0 : start + 1));
}

}  // namespace

// The night scene's four people in two captures: the warm blobs find all eight boxes and
// nothing else (measured: AP, precision and recall 1.0 at IoU 0.3, the silhouette boxes of the
// far people being a few pixels wide).
TEST(DetectEvalCli, SimulatedSceneAgainstTheSimulatorsPeople) {
  const auto r = run_thermovis(
      "detect-eval --scene night --scene-frames 2 --ir-detector warm-blob --iou 0.3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = last_json_line(r.output);
  EXPECT_EQ(j.at("scene"), "night");
  EXPECT_EQ(j.at("images").get<int>(), 2);
  EXPECT_EQ(j.at("persons").get<int>(), 8);
  EXPECT_EQ(j.at("detections").get<int>(), 8);
  EXPECT_DOUBLE_EQ(j.at("ap50").get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j.at("recall").get<double>(), 1.0);
}

TEST(DetectEvalCli, OneSourceOfFramesAndAKnownScene) {
  const auto both = run_thermovis("detect-eval --scene night --dir /tmp");
  EXPECT_NE(both.exit_code, 0);
  EXPECT_NE(both.output.find("--dir"), std::string::npos) << both.output;
  const auto none = run_thermovis("detect-eval");
  EXPECT_NE(none.exit_code, 0);
  const auto unknown = run_thermovis("detect-eval --scene no_such_scene");
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_NE(unknown.output.find("no_such_scene"), std::string::npos) << unknown.output;
}
