// `thermovis calibrate` end to end: outputs that load back, and bad input that fails cleanly
// (non-zero exit, a message naming the cause, nothing written).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "thermovis/camera/ocam_io.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/data.hpp"

namespace fs = std::filesystem;

namespace {

thermovis::test::CommandResult run(const std::string& args) {
  return thermovis::test::run_thermovis(args);
}

}  // namespace

TEST(CalibrateCli, MonoWritesYamlAndOcamFileAndJson) {
  THERMOVIS_REQUIRE_DATA(dir, "calib/ocamcalib_vmrimage/images");
  const fs::path out = thermovis::test::temp_dir("calibrate_cli_mono");
  const auto r = run("calibrate --images " + dir.string() + " --board 6x7 --square 30 --out " +
                     (out / "cam.yaml").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j.at("images_total").get<int>(), 10);
  EXPECT_EQ(j.at("images_used").get<int>(), 10);
  EXPECT_LT(j.at("rms_2d_px").get<double>(), 0.36);
  EXPECT_EQ(j.at("views").size(), 10u);
  const auto yaml = thermovis::runtime::load_taylor_yaml(out / "cam.yaml");
  const auto ocam = thermovis::camera::read_ocam_calib_results(out / "calib_results.txt");
  EXPECT_NEAR(yaml.pol[0], j.at("model").at("pol").at(0).get<double>(), 1e-6);
  EXPECT_NEAR(ocam.xc, yaml.xc, 1e-3);
  EXPECT_NEAR(yaml.pol[0], -131.9, 1.0);  // Urban 2015: -131.92

  // The corners written by --save-corners calibrate to the same result through --corners.
  const auto saved = run("calibrate --images " + dir.string() + " --board 6x7 --square 30 --out " +
                         (out / "a.yaml").string() + " --save-corners " +
                         (out / "corners.json").string() + " --json");
  ASSERT_EQ(saved.exit_code, 0) << saved.output;
  const auto again = run("calibrate --corners " + (out / "corners.json").string() +
                         " --board 6x7 --square 30 --out " + (out / "b.yaml").string() + " --json");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NEAR(nlohmann::json::parse(again.output).at("rms_2d_px").get<double>(),
              j.at("rms_2d_px").get<double>(), 1e-6);
}

TEST(CalibrateCli, StereoWritesALoadableRig) {
  THERMOVIS_REQUIRE_DATA(dir, "calib/opencv_stereo/images");
  const fs::path out = thermovis::test::temp_dir("calibrate_cli_stereo");
  std::string left, right;
  for (int k : {1, 2, 3, 4, 5, 6}) {
    const std::string index = std::to_string(k);
    left.append(" ").append((dir / ("left0" + index + ".jpg")).string());
    right.append(" ").append((dir / ("right0" + index + ".jpg")).string());
  }
  const auto r = run("calibrate --left" + left + " --right" + right +
                     " --board 9x6 --square 25 --pixel-pitch-um 6 --names cam.l,cam.r --out " +
                     (out / "rig.yaml").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j.at("pairs_used").get<int>(), 6);
  EXPECT_LT(j.at("rms_2d_px").get<double>(), 0.45);
  const auto rig = thermovis::runtime::load_rig(out / "rig.yaml");
  EXPECT_NEAR(rig.baseline_m("cam.l", "cam.r"), 0.0836, 0.003);  // 3.344 squares of 25 mm
}

TEST(CalibrateCli, BadInputFailsCleanly) {
  THERMOVIS_REQUIRE_DATA(dir, "calib/ocamcalib_vmrimage/images");
  const fs::path out = thermovis::test::temp_dir("calibrate_cli_bad");
  const std::string yaml = (out / "c.yaml").string();
  struct Case {
    std::string args, expected;
  };
  const Case cases[] = {
      {"--images /nonexistent/folder --board 6x7 --square 30", "/nonexistent/folder"},
      {"--images " + (dir / "VMRImage0.jpg").string() + " " + (dir / "VMRImage1.jpg").string() +
           " " + (dir / "VMRImage2.jpg").string() + " --board 9x9 --square 30",
       "at least 3 are needed"},
      {"--images " + dir.string() + " --board 6by7 --square 30", "6by7"},
      {"--images " + (dir / "VMRImage0.jpg").string() + " " + (dir / "VMRImage1.jpg").string() +
           " --board 6x7 --square 30",
       "at least 3"},
      {"--images " + dir.string() + " --board 6x7 --square -1", "--square"},
      {"--corners " + (out / "missing.json").string() + " --board 6x7 --square 30", "missing.json"},
  };
  for (const auto& c : cases) {
    const auto r = run("calibrate " + c.args + " --out " + yaml);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_FALSE(fs::exists(yaml)) << c.args;
    EXPECT_FALSE(fs::exists(out / "calib_results.txt")) << c.args;
  }
  // A corners file with a bad entry names the file, the view, the corner or field and the fault.
  const std::pair<std::string, std::string> corner_files[] = {
      {R"({"image_size": [640, 480], "views": [{"name": "a", "corners": [[1, 2], "x"]}]})",
       "view 0 (a) corner 1: must be [x, y] or null"},
      {R"({"image_size": [640], "views": []})", "field 'image_size' must be [width, height]"},
      {R"({"image_size": [640, 480], "views": [{"corners": []}]})", "view 0: field 'name' missing"},
      {R"({"image_size": [640, 480], "views": [{"name": "b", "corners": [[1, 2], null]}]})",
       "view 0 (b) has 2 corners, the board 42"},
      {R"({"image_size": [640, 480], "views": {"name": "c"}})", "field 'views' must be an array"},
  };
  for (const auto& [text, expected] : corner_files) {
    std::ofstream(out / "bad_corners.json") << text;
    const auto r = run("calibrate --corners " + (out / "bad_corners.json").string() +
                       " --board 6x7 --square 30 --out " + yaml);
    EXPECT_NE(r.exit_code, 0) << text;
    EXPECT_NE(r.output.find("bad_corners.json"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(expected), std::string::npos) << text << "\n" << r.output;
    EXPECT_FALSE(fs::exists(yaml)) << text;
  }
  // An unreadable image is named.
  std::ofstream(out / "broken.jpg") << "not an image";
  const auto r = run("calibrate --images " + (out / "broken.jpg").string() +
                     " --board 6x7 --square 30 --out " + yaml);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("broken.jpg"), std::string::npos) << r.output;
}
