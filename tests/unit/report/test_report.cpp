// `thermovis report --from DIR` formats saved runs (runs.json + one file of JSON lines per run)
// into RESULTS.md: canned rows in the shapes the benches print give known table rows, and a bad
// row is an error naming its file and line.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "thermovis/test/data.hpp"

namespace fs = std::filesystem;
using thermovis::test::run_thermovis;

namespace {

void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// One row of `thermovis bench ranging --json` for 2 trials; the statistics as JSON text
// ("null" where nothing was ranged).
std::string ranging_row(int distance_m, const std::string& mode, int ranged,
                        const std::string& mean_abs, const std::string& mean_signed,
                        const std::string& max_abs, const std::string& within_sigma,
                        const std::string& sigma, double paper) {
  return "{\"distance_m\":" + std::to_string(distance_m) + ",\"mode\":\"" + mode +
         "\",\"trials\":2,\"ranged\":" + std::to_string(ranged) +
         ",\"failures\":" + std::to_string(2 - ranged) + ",\"mean_abs_error_m\":" + mean_abs +
         ",\"mean_signed_error_m\":" + mean_signed + ",\"max_abs_error_m\":" + max_abs +
         ",\"within_1_sigma\":" + within_sigma + ",\"mean_sigma_m\":" + sigma +
         ",\"eq2_error_at_0.1px_m\":0.01,\"paper_abs_error_m\":" + std::to_string(paper) + "}\n";
}

// A runs folder with a ranging run (two distances, two modes, one distance never ranged in
// infrared), a matching run and two calibration sets, as `thermovis report` writes it.
fs::path canned_runs(const std::string& name) {
  const fs::path dir = thermovis::test::temp_dir(name);
  write(dir / "runs.json", R"({"machine": {"cpu": "Test CPU @ 1.00GHz", "cores": 2,
      "date": "2030-01-02 03:04 UTC", "load_average": 1.5}, "quick": true,
    "command": "thermovis report --quick",
    "runs": [
      {"kind": "ranging", "label": "", "file": "1-ranging.jsonl",
       "command": "thermovis bench ranging --trials 2 --mode all --seed 7 --json"},
      {"kind": "match", "label": "", "file": "2-match.jsonl",
       "command": "thermovis match-eval --data D --methods ncc --json"},
      {"kind": "calibration", "label": "fisheye1", "file": "3-calibration.jsonl",
       "command": "thermovis calibrate --images D/calib/ocamcalib_fisheye1 --json"},
      {"kind": "calibration", "label": "ladybug", "file": "4-calibration.jsonl",
       "command": "thermovis calibrate --images D/calib/ocamcalib_ladybug --json"},
      {"kind": "detection", "label": "llvip_dev: infrared classifier", "file": "5-detection.jsonl",
       "command": "thermovis detect-eval --dir D/detect/llvip_dev --json"}]})");
  write(dir / "5-detection.jsonl",
        R"({"persons":91,"detections":182,"true_positives":68,"ap50":0.5754,"precision":0.3736,)"
        R"("recall":0.7473,"images":21,"ms_per_image":34.31,"by_height":[)"
        R"({"bucket":"<30","persons":0,"ap50":0},{"bucket":"30-80","persons":0,"ap50":0},)"
        R"({"bucket":">80","persons":91,"ap50":0.5968}],"errors":[]})"
        "\n");
  write(dir / "1-ranging.jsonl",
        "trial 1/2 done (3 s)\n" +
            ranging_row(5, "visible", 2, "0.0214", "-0.0104", "0.0391", "0.5", "0.0183", 0.18) +
            ranging_row(5, "infrared", 1, "0.03", "0.03", "0.03", "1.0", "0.04", 0.05) +
            ranging_row(60, "visible", 1, "0.36", "-0.36", "0.36", "0.0", "0.5", 3.24) +
            ranging_row(60, "infrared", 0, "null", "null", "null", "null", "null", 2.55));
  write(dir / "2-match.jsonl",
        R"({"method":"ncc","subpixel":true,"scenes":5,"matches_per_pair":1210.4,)"
        R"("within_1px":0.9163,"within_half_px":0.8531,"mean_abs_error_px_inliers":0.2468,)"
        R"("ms_per_pair":33.27,"per_scene":[]})"
        "\n"
        R"({"dense_method":"bm","bad1":0.4105,"bad2":0.3933,"valid":0.6504,"bad1_valid":0.0936,)"
        R"("ms_per_pair":11.28,"scenes":5,"per_scene":[]})"
        "\n");
  const std::string mono =
      R"({"rms_2d_px":0.40134,"linear_rms_2d_px":2.5,"images_used":15,"images_total":15,)"
      R"("images_with_board":15,"corners_used":720,"corners_rejected":0,"model":)"
      R"({"image_size":[1032,778],"centre_row_col":[377.81,543.79],"affine_cde":[1,0,0],)"
      R"("pol":[-338.452,0,0.0005],"invpol":[1]},"views":[]})";
  write(dir / "3-calibration.jsonl", mono + "\n");
  std::string ladybug = mono;
  ladybug.replace(ladybug.find("0.40134"), 7, "0.39660");
  write(dir / "4-calibration.jsonl", ladybug + "\n");
  return dir;
}

}  // namespace

TEST(Report, FormatsCannedRowsIntoTablesNamingTheirCommands) {
  const fs::path dir = canned_runs("report_tables");
  const fs::path out = dir / "RESULTS.md";
  const auto r = run_thermovis("report --from " + dir.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string md = read(out);
  // The machine and the generating command head the page; each table names its command.
  EXPECT_NE(md.find("Generated by `thermovis report --quick`"), std::string::npos) << md;
  EXPECT_NE(md.find("Machine: Test CPU @ 1.00GHz, 2 cores, load average 1.5"), std::string::npos)
      << md;
  EXPECT_NE(md.find("2030-01-02 03:04 UTC"), std::string::npos) << md;
  EXPECT_NE(md.find("**Quick mode**"), std::string::npos) << md;
  EXPECT_NE(md.find("`thermovis bench ranging --trials 2 --mode all --seed 7 --json`"),
            std::string::npos)
      << md;
  // Ranging: modes as columns in first-seen order, a distance never ranged shows "-".
  EXPECT_NE(md.find("| m | visible | infrared |\n|---|---|---|\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| 5 | 0.021 / 0.039, 2/2 (0.18) | 0.030 / 0.030, 1/2 (0.05) |\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| 60 | 0.360 / 0.360, 1/2 (3.24) | -, 0/2 (2.55) |\n"), std::string::npos)
      << md;
  EXPECT_NE(md.find("| 5 | -0.010, 0.018, 50 % | 0.030, 0.040, 100 % |\n"), std::string::npos)
      << md;
  EXPECT_NE(md.find("| 60 | -0.360, 0.500, 0 % | -, -, - |\n"), std::string::npos) << md;
  // As disparity: 0.0214 m at 0.01 m per 0.1 px is 0.214 px; the paper's 0.18 m 1.8 px.
  EXPECT_NE(md.find("| 5 | 0.214 / 1.800 | 0.300 / 0.500 |\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| 60 | 3.600 / 32.400 | - / 25.500 |\n"), std::string::npos) << md;
  // Matching: one row per method.
  EXPECT_NE(md.find("| ncc | 5 | 1210 | 91.6 % | 85.3 % | 0.247 px | 33.3 |\n"), std::string::npos)
      << md;
  // Calibration: both sets in one table, one row each, under both commands.
  EXPECT_NE(md.find("| fisheye1 | 15/15 | 720 (0) | 0.4013 | 2.5000 | -338.45 | 377.8, 543.8 |\n"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| ladybug | 15/15 | 720 (0) | 0.3966 |"), std::string::npos) << md;
  EXPECT_NE(md.find("`thermovis calibrate --images D/calib/ocamcalib_ladybug --json`"),
            std::string::npos)
      << md;
  // Dense methods get their own table under the sparse ones.
  EXPECT_NE(md.find("| bm | 41.0 % | 39.3 % | 65.0 % | 9.4 % | 11.3 |\n"), std::string::npos) << md;
  // Detection: one row per set and detector; a height bucket without people shows "-".
  EXPECT_NE(md.find("| llvip_dev: infrared classifier | 21 | 91 | 0.575 | 0.374 | 0.747 | - | - | "
                    "0.597 (91) | 34.3 |\n"),
            std::string::npos)
      << md;
  // Sections without runs (fusion, pipeline) are left out rather than printed empty.
  EXPECT_EQ(md.find("VIFB"), std::string::npos) << md;
  EXPECT_EQ(md.find("capture to range"), std::string::npos) << md;
}

TEST(Report, RangingRunsOfOneLabelArePooledAndLabelsGetTheirOwnTables) {
  const fs::path dir = canned_runs("report_pooled");
  // A second seed on the same grid, and a run on another grid.
  write(dir / "runs.json", R"({"machine": {"cpu": "Test CPU", "cores": 2,
      "date": "2030-01-02 03:04 UTC", "load_average": 1.5}, "quick": false,
    "command": "thermovis report",
    "runs": [
      {"kind": "ranging", "label": "grid A", "file": "1-ranging.jsonl", "command": "seed 1"},
      {"kind": "ranging", "label": "grid A", "file": "5-ranging.jsonl", "command": "seed 2"},
      {"kind": "ranging", "label": "grid B", "file": "6-ranging.jsonl", "command": "seed 1 B"}]})");
  write(dir / "5-ranging.jsonl",
        ranging_row(5, "visible", 2, "0.0614", "0.0296", "0.0791", "1.0", "0.0383", 0.18) +
            ranging_row(5, "infrared", 2, "0.06", "0.06", "0.09", "0.5", "0.07", 0.05) +
            ranging_row(60, "visible", 0, "null", "null", "null", "null", "null", 3.24) +
            ranging_row(60, "infrared", 1, "0.5", "0.5", "0.5", "1.0", "0.6", 2.55));
  write(dir / "6-ranging.jsonl",
        ranging_row(5, "visible", 1, "0.1", "0.1", "0.1", "1.0", "0.2", 0.18));
  const fs::path out = dir / "RESULTS.md";
  const auto r = run_thermovis("report --from " + dir.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string md = read(out);
  const auto a = md.find("### grid A"), b = md.find("### grid B");
  ASSERT_NE(a, std::string::npos) << md;
  ASSERT_NE(b, std::string::npos) << md;
  const std::string grid_a = md.substr(a, b - a), grid_b = md.substr(b);
  // visible 5 m: (2 x 0.0214 + 2 x 0.0614) / 4 = 0.0414, max 0.0791, 4 of 4; bias
  // (2 x -0.0104 + 2 x 0.0296) / 4 = 0.0096, sigma 0.0283, within (0.5 + 1.0) / 2.
  // infrared 5 m: (0.03 + 2 x 0.06) / 3 = 0.05, 3 of 4.
  EXPECT_NE(grid_a.find("| 5 | 0.041 / 0.079, 4/4 (0.18) | 0.050 / 0.090, 3/4 (0.05) |\n"),
            std::string::npos)
      << grid_a;
  EXPECT_NE(grid_a.find("| 5 | 0.010, 0.028, 75 % |"), std::string::npos) << grid_a;
  // 60 m: one ranged in each mode over the two seeds.
  EXPECT_NE(grid_a.find("| 60 | 0.360 / 0.360, 1/4 (3.24) | 0.500 / 0.500, 1/4 (2.55) |\n"),
            std::string::npos)
      << grid_a;
  EXPECT_NE(grid_b.find("| 5 | 0.100 / 0.100, 1/2 (0.18) |\n"), std::string::npos) << grid_b;
}

TEST(Report, PipelineRunGivesItsStagesAndWhatOfItsTailsFellInTheMachinesStalls) {
  const fs::path dir = canned_runs("report_pipeline");
  write(dir / "runs.json", R"({"machine": {"cpu": "Test CPU", "cores": 2,
      "date": "2030-01-02 03:04 UTC", "load_average": 1.5}, "quick": false,
    "command": "thermovis report",
    "runs": [{"kind": "pipeline", "label": "", "file": "1-pipeline.jsonl",
              "command": "thermovis bench pipeline --seconds 20 --warmup 5 --json"}]})");
  write(dir / "1-pipeline.jsonl",
        R"({"frames":1000,"seconds":20,"p50_ms":9.71,"p99_ms":17.36,"max_ms":24.5,)"
        R"("over_deadline":5,"dropped":0,"deadline_misses":12,"bad_inputs":0,"restarts":0,)"
        R"("ranges":8000,"ranges_on_target":8000,"mean_abs_error_m":0.2237,)"
        R"("mean_abs_relative_error":0.0064,"p95_abs_error_m":1.087,)"
        R"("stages":{"match":{"p50_ms":2.16,"p99_ms":3.23,"max_ms":12.3,"done_p50_ms":8.78}},)"
        R"("processes":{"match":{"cpu_percent":25.4,"rss_mb":79.6,"scheduling":"fifo 10"}},)"
        R"("host_stalls":{"probe":"fifo 50","cpus":[0,1],"over_5ms":10,"over_10ms":2,)"
        R"("max_ms":12.79,"total_ms":225.3,"over_5ms_by_cpu":{"0":5,"1":5},)"
        R"("over_deadline_in_stalls":4,"deadline_misses":12,"deadline_misses_in_stalls":10,)"
        R"("deadline_misses_outside_stalls_by_endpoint":{}}})"
        "\n");
  const fs::path out = dir / "RESULTS.md";
  const auto r = run_thermovis("report --from " + dir.string() + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string md = read(out);
  EXPECT_NE(md.find("| capture to range | 9.7 | 17.4 | 24.5 | 9.7 |\n"), std::string::npos) << md;
  EXPECT_NE(md.find("| stage match | 2.2 | 3.2 | 12.3 | 8.8 |\n"), std::string::npos) << md;
  EXPECT_NE(md.find("The machine's CPUs stopped 10 times for 5 ms or more (2 for 10 ms or more, "
                    "longest 12.8 ms, seen by a probe at fifo 50 on each CPU); 4 of the 5 frames "
                    "over the deadline and 10 of the 12 DEADLINE misses fell in one."),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| match | 25 | 80 | fifo 10 |\n"), std::string::npos) << md;
}

TEST(Report, ABadRowNamesItsFileAndLine) {
  const fs::path dir = canned_runs("report_bad_row");
  write(dir / "2-match.jsonl", "{\"method\": \"ncc\",\n{oops\n");
  const auto r =
      run_thermovis("report --from " + dir.string() + " --out " + (dir / "RESULTS.md").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2-match.jsonl:1: not JSON"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "RESULTS.md"));
}

TEST(Report, AMissingFieldNamesTheRunAndTheField) {
  const fs::path dir = canned_runs("report_missing_field");
  write(dir / "2-match.jsonl", R"({"method":"ncc","scenes":5})"
                               "\n");
  const auto r =
      run_thermovis("report --from " + dir.string() + " --out " + (dir / "RESULTS.md").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2-match.jsonl (match)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("matches_per_pair"), std::string::npos) << r.output;
}
