// Rig YAML: the shipped paper rig, and clear errors for broken rig files.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"
#include "thermovis/test/data.hpp"

namespace tc = thermovis::camera;
namespace tr = thermovis::runtime;

namespace {

std::string paper_text() {
  std::ifstream in(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string error_of(const std::string& text) {
  try {
    tr::parse_rig(text, "rig.yaml");
  } catch (const tr::ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(Rig, PaperRigHasFourCamerasAndTheTablesBaselines) {
  const tc::Rig rig = tr::parse_rig(paper_text(), "paper.yaml");
  EXPECT_EQ(rig.cameras.size(), 4u);
  EXPECT_EQ(rig.reference, "visible.left");
  // Table 4: |T| = 336.1 mm; Table 5: |T| = 357.8 mm.
  EXPECT_NEAR(rig.baseline_m("visible.left", "visible.right"), 0.3361, 1e-3);
  EXPECT_NEAR(rig.baseline_m("infrared.left", "infrared.right"), 0.3578, 1e-3);
  // X_right = R X_left + T: the right camera centre in the left frame is -R^T T, about +335 mm in
  // x.
  const Eigen::Vector3d right_centre = rig.camera("visible.right").T_ref_cam.translation();
  EXPECT_NEAR(right_centre.x(), 0.335, 0.005);
  EXPECT_FALSE(rig.notes.empty());
  EXPECT_EQ(rig.camera("infrared.left").bit_depth, 14);
}

TEST(Rig, WriteThenParseGivesTheSamePoses) {
  const tc::Rig rig = tr::parse_rig(paper_text(), "paper.yaml");
  const tc::Rig back = tr::parse_rig(tr::rig_to_yaml(rig), "written.yaml");
  for (const auto& cam : rig.cameras) {
    const auto& other = back.camera(cam.name);
    EXPECT_LT((cam.T_ref_cam.matrix() - other.T_ref_cam.matrix()).cwiseAbs().maxCoeff(), 1e-9)
        << cam.name;
    Eigen::Vector2d a, b;
    ASSERT_TRUE(cam.model->project({0.2, -0.1, 1.0}, a));
    ASSERT_TRUE(other.model->project({0.2, -0.1, 1.0}, b));
    EXPECT_LT((a - b).norm(), 1e-6);
  }
}

TEST(Rig, BrokenFilesGiveErrorsNamingLineAndKey) {
  const std::string text = paper_text();
  const std::string unknown = error_of(replace(text, "    bit_depth: 8\n", "    bit_dept: 8\n"));
  EXPECT_NE(unknown.find("unknown key 'bit_dept'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("rig.yaml:"), std::string::npos) << unknown;

  const std::string missing =
      error_of(replace(text, "      pol: [-835.384,", "      poll: [-835.384,"));
  EXPECT_NE(missing.find("poll"), std::string::npos) << missing;

  const std::string not_number =
      error_of(replace(text, "pixel_pitch_um: 13", "pixel_pitch_um: thirteen"));
  EXPECT_NE(not_number.find("pixel_pitch_um"), std::string::npos) << not_number;

  const std::string nan = error_of(replace(text, "[-835.384, 0,", "[.nan, 0,"));
  EXPECT_NE(nan.find("finite"), std::string::npos) << nan;

  const std::string rotation =
      error_of(replace(text, "[[0.9976, -0.0009, 0.0684]", "[[0.5, -0.0009, 0.0684]"));
  EXPECT_NE(rotation.find("not a rotation"), std::string::npos) << rotation;

  const std::string unknown_camera =
      error_of(replace(text, "to: visible.right", "to: visible.middle"));
  EXPECT_NE(unknown_camera.find("visible.middle"), std::string::npos) << unknown_camera;

  const std::string syntax = error_of("name: [unclosed\n");
  EXPECT_NE(syntax.find("rig.yaml:"), std::string::npos) << syntax;

  EXPECT_THROW(tr::load_rig("/nonexistent/rig.yaml"), tr::ConfigError);
}

}  // namespace
