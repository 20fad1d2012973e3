// `thermovis range` and `thermovis bench ranging` as a user runs them: a simulated frame set
// written by `thermovis scene render` ranged in every mode (JSON lines against the truth the
// folder carries), boxes that cannot be ranged, a missing folder, and the Table 6 bench's rows.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "thermovis/test/data.hpp"

namespace fs = std::filesystem;
using thermovis::test::run_thermovis;

namespace {

std::vector<nlohmann::json> json_lines(const std::string& output) {
  std::vector<nlohmann::json> out;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.front() == '{') out.push_back(nlohmann::json::parse(line));
  }
  return out;
}

// One rendered frame of the paper's scene (people at 5-60 m) in the test's own folder.
fs::path render_frame(const std::string& name) {
  const fs::path dir = thermovis::test::temp_dir(name);
  const auto r = run_thermovis("scene render --scene paper --out " + dir.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return dir / "000000";
}

}  // namespace

TEST(RangeCli, RangesTheRenderedPeopleInEveryMode) {
  const fs::path frame = render_frame("range_cli_modes");
  ASSERT_TRUE(fs::exists(frame / "truth.json"));
  for (const std::string mode : {"visible", "infrared", "fused"}) {
    // On the visible camera's full grid: the pipeline's default half grid leaves the visible
    // pair too few corners on some people beyond 10 m (docs/LIMITS.md).
    const auto r = run_thermovis("range --images " + frame.string() + " --mode " + mode +
                                 " --grid-scale 1 --json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    int near_people = 0;
    for (const auto& t : json_lines(r.output)) {
      EXPECT_EQ(t.at("mode"), mode);
      if (t.at("class") != "person") continue;
      const double truth = t.at("truth_distance_m").get<double>();
      if (t.at("status") != "ok") {
        // No distance is never a made-up one, and says why.
        EXPECT_TRUE(t.at("distance_m").is_null()) << t;
        EXPECT_FALSE(t.at("message").get<std::string>().empty()) << t;
        EXPECT_GT(truth, 21.0) << mode << ": a person at " << truth << " m not ranged: " << t;
        continue;
      }
      const double distance = t.at("distance_m").get<double>();
      EXPECT_LT(std::abs(distance - truth), 0.05 * truth + 0.1) << mode << " " << t;
      EXPECT_GT(t.at("sigma_m").get<double>(), 0.0) << t;
      if (truth < 21.0) ++near_people;
      if (mode == "fused") {
        // Each pair's own range is reported beside the combination.
        const auto& bands = t.at("bands");
        for (const char* band : {"visible", "infrared"}) {
          ASSERT_TRUE(bands.contains(band)) << t;
          EXPECT_EQ(bands.at(band).at("box").size(), 4u) << t;
        }
        // The combination uses the points of the pairs that gave a range.
        int used = 0;
        for (const char* band : {"visible", "infrared"}) {
          if (bands.at(band).at("status") == "ok")
            used += bands.at(band).at("points_used").get<int>();
        }
        EXPECT_EQ(used, t.at("points_used").get<int>()) << t;
      }
    }
    EXPECT_EQ(near_people, 4) << mode << ": the people at 5, 10, 15 and 20 m";
  }
}

TEST(RangeCli, BadBoxesAndAMissingFolderSayWhy) {
  const fs::path frame = render_frame("range_cli_boxes");
  const fs::path boxes = frame.parent_path() / "boxes.json";
  std::ofstream(boxes) << R"({"targets": [
    {"id": "outside", "class": "person", "rectified_box": [5000, 100, 5040, 200]},
    {"id": "empty", "class": "person", "rectified_box": [700, 400, 700, 400]},
    {"id": "sky", "class": "person", "rectified_box": [900, 20, 960, 80]}]})";
  for (const std::string mode : {"visible", "fused"}) {
    const auto r = run_thermovis("range --images " + frame.string() + " --boxes " + boxes.string() +
                                 " --mode " + mode + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    std::map<std::string, std::string> status;
    for (const auto& t : json_lines(r.output)) {
      status[t.at("id")] = t.at("status");
      EXPECT_TRUE(t.at("distance_m").is_null()) << t;
      EXPECT_FALSE(t.at("message").get<std::string>().empty()) << t;
    }
    EXPECT_EQ(status["outside"], "box_outside_image") << mode;
    EXPECT_EQ(status.count("empty"), 1u) << mode;
    EXPECT_NE(status["empty"], "ok") << mode;
    EXPECT_NE(status["sky"], "ok") << mode;
  }
  const auto missing = run_thermovis("range --images /nonexistent/frame --json");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("/nonexistent/frame"), std::string::npos) << missing.output;
}

// --bound: the least mean |error| each person's pixels allow, beside the same trials' errors
// (the noise-free render draws nothing from the trials' random sequence).
TEST(BenchRangingCli, BoundsWhatThePixelsAllowOnTheSameTrials) {
  const std::string args = "bench ranging --trials 2 --distances 10,40 --mode all --seed 3 --json";
  const auto plain = run_thermovis(args);
  const auto bounded = run_thermovis(args + " --bound");
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  ASSERT_EQ(bounded.exit_code, 0) << bounded.output;
  const auto a = json_lines(plain.output), b = json_lines(bounded.output);
  ASSERT_EQ(a.size(), 6u) << plain.output;
  ASSERT_EQ(b.size(), 6u) << bounded.output;
  std::map<std::pair<double, std::string>, double> bound;
  const auto at = [&](double d, const std::string& mode) { return bound[std::make_pair(d, mode)]; };
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_FALSE(a[i].contains("bound_mean_abs_m")) << a[i];
    EXPECT_EQ(a[i].at("mean_abs_error_m"), b[i].at("mean_abs_error_m")) << b[i];
    ASSERT_TRUE(b[i].contains("bound_mean_abs_m")) << b[i];
    const double v = b[i].at("bound_mean_abs_m").get<double>();
    EXPECT_GT(v, 0.0) << b[i];
    EXPECT_TRUE(std::isfinite(v)) << b[i];
    EXPECT_EQ(b[i].at("bounds"), 2) << b[i];
    bound[{b[i].at("distance_m").get<double>(), b[i].at("mode").get<std::string>()}] = v;
  }
  for (const std::string mode : {"visible", "infrared", "fused"}) {
    // Farther: fewer pixels, and metres per pixel of disparity growing as the square.
    EXPECT_GT(at(40.0, mode), 4 * at(10.0, mode)) << mode;
  }
  for (const double d : {10.0, 40.0}) {
    // Both pairs together allow less error than either alone.
    EXPECT_LT(at(d, "fused"), at(d, "visible")) << d;
    EXPECT_LT(at(d, "fused"), at(d, "infrared")) << d;
  }
}

TEST(BenchRangingCli, PrintsTable6RowsForScripts) {
  const auto r =
      run_thermovis("bench ranging --trials 2 --distances 10,25 --mode all --seed 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto rows = json_lines(r.output);
  ASSERT_EQ(rows.size(), 6u) << r.output;
  for (const auto& row : rows) {
    for (const char* key : {"distance_m", "mode", "trials", "mean_abs_error_m", "max_abs_error_m",
                            "within_1_sigma", "paper_abs_error_m"}) {
      EXPECT_TRUE(row.contains(key)) << key << " missing: " << row;
    }
    EXPECT_EQ(row.at("trials"), 2);
    if (row.at("distance_m") == 10.0) {
      // Every mode ranges a person at 10 m, to a fraction of a metre.
      EXPECT_EQ(row.at("ranged"), 2) << row;
      EXPECT_LT(row.at("mean_abs_error_m").get<double>(), 0.3) << row;
      EXPECT_LE(row.at("mean_abs_error_m").get<double>(), row.at("max_abs_error_m").get<double>());
    }
  }
  EXPECT_DOUBLE_EQ(rows[2].at("paper_abs_error_m").get<double>(), 0.00);  // 10 m fused
  EXPECT_DOUBLE_EQ(rows[3].at("paper_abs_error_m").get<double>(), 0.86);  // 25 m visible

  const auto bad = run_thermovis("bench ranging --distances 10,far --json");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("'far'"), std::string::npos) << bad.output;
}
