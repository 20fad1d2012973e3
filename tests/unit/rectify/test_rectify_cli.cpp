// `thermovis rectify` end to end: a synthetic pair through the CLI, its JSON figures, and clear
// errors on bad input.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "thermovis/test/data.hpp"

namespace {

struct CliRun {
  int status = -1;
  std::string out, err;
};

CliRun run_thermovis(const std::string& args, const std::filesystem::path& dir) {
  const auto out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command = (thermovis::test::bin_dir() / "thermovis").string() + " " + args +
                              " >" + out.string() + " 2>" + err.string();
  CliRun r;
  r.status = std::system(command.c_str());
  auto slurp = [](const std::filesystem::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

class RectifyCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(thermovis::test::bin_dir() / "thermovis")) {
      GTEST_SKIP() << "thermovis not built in " << thermovis::test::bin_dir();
    }
    dir_ = thermovis::test::temp_dir("rectify-cli");
  }
  void TearDown() override {
    if (!dir_.empty()) std::filesystem::remove_all(dir_);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::filesystem::path dir_;
};

TEST_F(RectifyCli, InfraredPairWithJsonFigures) {
  const CliRun r = run_thermovis("rectify --pair infrared --checkerboard --left " + path("l.png") +
                                     " --right " + path("r.png") + " --out-left " + path("lr.png") +
                                     " --out-right " + path("rr.png") + " --json",
                                 dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["cameras"].size(), 2u);
  for (const auto& cam : j["cameras"]) {
    EXPECT_GE(cam["field_kept_deg"].get<double>(), 120.0) << cam["camera"];
    EXPECT_EQ(cam["table_bytes"].get<std::size_t>(), 4u * cam["output_size"][0].get<std::size_t>() *
                                                         cam["output_size"][1].get<std::size_t>());
    EXPECT_FALSE(cam["quarter_symmetric"].get<bool>());  // real rig: rotated, off-centre
  }
  const cv::Mat left = cv::imread(path("lr.png"), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(left.type(), CV_16UC1);
  EXPECT_EQ(left.cols, j["cameras"][0]["output_size"][0].get<int>());
}

TEST_F(RectifyCli, EllipticalQuarterTableIsAQuarter) {
  const CliRun r = run_thermovis(
      "rectify --camera infrared.right --model elliptical --checkerboard "
      "--quarter --reference --in " +
          path("raw.png") + " --out " + path("out.png") + " --export-table " + path("t.bin") +
          " --json",
      dir_);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto cam = nlohmann::json::parse(r.out)["cameras"][0];
  EXPECT_EQ(cam["quarter_table_bytes"].get<std::size_t>() * 4,
            cam["table_bytes"].get<std::size_t>());
  EXPECT_EQ(std::filesystem::file_size(path("t.bin")),
            cam["quarter_table_bytes"].get<std::size_t>());
  EXPECT_EQ(cam["stored_table"], "quarter");
}

TEST_F(RectifyCli, BadInputGivesAClearError) {
  cv::imwrite(path("small.png"), cv::Mat(100, 120, CV_8UC1, cv::Scalar(7)));
  std::ofstream(path("junk.png")) << "not an image";
  const struct {
    std::string args, expected;
  } cases[] = {
      {"rectify --camera visible.left --in " + path("missing.png") + " --out " + path("o.png"),
       "does not exist"},
      {"rectify --camera visible.left --in " + path("junk.png") + " --out " + path("o.png"),
       "cannot read image"},
      {"rectify --camera visible.left --in " + path("small.png") + " --out " + path("o.png"),
       "is 120x100 but camera visible.left is 1920x1080"},
      {"rectify --camera visible.middle --in " + path("small.png") + " --out " + path("o.png"),
       "visible.middle"},
      {"rectify --pair thermal --left a --right b --out-left c --out-right d", "unknown pair"},
      {"rectify --camera visible.left --model elliptical --quarter --onto-visible --in x --out y",
       "--onto-visible"},
  };
  for (const auto& c : cases) {
    const CliRun r = run_thermovis(c.args, dir_);
    EXPECT_NE(r.status, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos)
        << c.args << "\nstderr: " << r.err << "\nexpected: " << c.expected;
  }
  // The Taylor map of the real rig is not symmetric: --quarter is refused with the reason.
  cv::imwrite(path("raw.png"), cv::Mat(768, 1024, CV_16UC1, cv::Scalar(1000)));
  const CliRun r = run_thermovis("rectify --camera infrared.left --quarter --in " +
                                     path("raw.png") + " --out " + path("o.png"),
                                 dir_);
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("quarter table refused"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(path("o.png")));
}

}  // namespace
