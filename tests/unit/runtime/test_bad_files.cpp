// Bad files of every kind a user hands the system: the supervisor's manifest, rigs, scenes and
// calibration files (one camera's YAML, OCamCalib's calib_results.txt). Each mistake (missing
// file, empty file, not YAML, wrong types, missing keys, NaN/inf, absurd sizes) is an error of the
// reader's documented type whose message names the file and what is wrong.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "thermovis/camera/ocam_io.hpp"
#include "thermovis/process/manifest_io.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"
#include "thermovis/test/data.hpp"

namespace {

namespace fs = std::filesystem;
namespace rt = thermovis::runtime;
using rt::ConfigError;

std::string read(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// `text` with `from` replaced by `to` (which must occur).
std::string with(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("test text has no '" + from + "'");
  return text.replace(at, from.size(), to);
}

struct Case {
  std::string name;
  std::string text;
  std::vector<std::string> says;  // fragments the message must hold (besides the file name)
};

// Writes each case to a file and loads it: the loader must throw Error naming the file and
// saying each fragment.
template <class Error>
void expect_errors(const std::string& kind, const std::function<void(const fs::path&)>& load,
                   const std::vector<Case>& cases) {
  const fs::path dir = thermovis::test::temp_dir("bad_" + kind);
  for (const Case& c : cases) {
    SCOPED_TRACE(kind + ": " + c.name);
    const fs::path file = dir / (c.name + ".txt");
    std::ofstream(file) << c.text;
    try {
      load(file);
      ADD_FAILURE() << "accepted:\n" << c.text;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(file.string()), std::string::npos) << "the file is not named: " << what;
      for (const std::string& fragment : c.says)
        EXPECT_NE(what.find(fragment), std::string::npos)
            << "'" << fragment << "' not in: " << what;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "unexpected exception type: " << e.what();
    }
  }
  // A file that is not there.
  const fs::path missing = dir / "missing.yaml";
  try {
    load(missing);
    ADD_FAILURE() << "a missing file was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(BadFiles, Manifest) {
  const std::string good = read(thermovis::test::source_root() / "deploy/pipeline.yaml");
  ASSERT_NO_THROW(thermovis::process::parse_manifest(good, "pipeline.yaml"));
  const std::string service = "  - name: detect\n";
  expect_errors<ConfigError>(
      "manifest", [](const fs::path& p) { thermovis::process::load_manifest(p); },
      {{"empty", "", {"empty manifest"}},
       {"comments_only", "# nothing here\n", {"empty manifest"}},
       {"not_yaml", "services: [bridge\n  - {name: x", {"YAML syntax"}},
       {"binary",
        std::string("\x7f"
                    "ELF\x02\x01\x01\0\0\0",
                    10),
        {}},
       {"a_list", "- bridge\n- range\n", {"expected a manifest map"}},
       {"no_services", "name: x\n", {"missing key 'services'"}},
       {"services_not_a_list", "services: bridge\n", {"services: expected a non-empty list"}},
       {"command_wrong_type",
        "services:\n  - name: a\n    command: 5\n",
        {"services.a.command", "non-empty list"}},
       {"missing_name", "services:\n  - command: [x]\n", {"missing key 'name'"}},
       {"unknown_key",
        with(good, service, service + "    restrat: always\n"),
        {"unknown key 'restrat'"}},
       {"unknown_policy",
        with(good, "restart: on-failure", "restart: sometimes"),
        {"'sometimes' is not one of"}},
       {"nan_timeout",
        with(good, service, service + "    stop_timeout_s: .nan\n"),
        {"stop_timeout_s", "finite"}},
       {"inf_backoff",
        with(good, service, service + "    backoff: {max_s: .inf}\n"),
        {"backoff.max_s", "finite"}},
       {"negative_timeout",
        with(good, service, service + "    stop_timeout_s: -1\n"),
        {"stop_timeout_s", "not in (0, 86400]"}},
       {"huge_timeout",
        with(good, service, service + "    stop_timeout_s: 1e300\n"),
        {"stop_timeout_s", "not in (0, 86400]"}},
       {"list_as_key",
        with(good, service, service + "    env: {[A]: b}\n"),
        {"env", "a key must be a plain name"}},
       {"depends_on_a_map",
        with(good, "depends_on: [bridge]", "depends_on: {bridge: 1}"),
        {"depends_on: expected a list"}},
       {"unknown_dependency",
        with(good, "depends_on: [bridge]", "depends_on: [brigde]"),
        {"unknown service 'brigde'"}},
       {"cycle",
        with(good, "  - name: bridge\n", "  - name: bridge\n    depends_on: [range]\n"),
        {"cycle"}}});
}

TEST(BadFiles, Rig) {
  const std::string good = read(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
  const std::string size = "image_size: [1024, 768]";
  expect_errors<ConfigError>(
      "rig", [](const fs::path& p) { rt::load_rig(p); },
      {{"empty", "", {"empty rig file"}},
       {"not_yaml", "cameras: {visible.left: [", {"YAML syntax"}},
       {"a_scalar", "just some text\n", {"rig: expected a map"}},
       {"missing_cameras", "name: x\nreference: a\n", {"missing key 'cameras'"}},
       {"missing_pol",
        with(good, "      pol: [-416.2053, 0, 4.635e-4, 5.35078e-8, -4.75532e-11]\n", ""),
        {"cameras.infrared.left.model", "missing key 'pol'"}},
       {"pol_a_string", with(good, "pol: [-416.2053,", "pol: [abc,"), {"pol", "finite number"}},
       {"pol_nan", with(good, "pol: [-416.2053,", "pol: [.nan,"), {"pol", "finite number"}},
       {"centre_inf",
        with(good, "centre_row_col: [351.7304", "centre_row_col: [.inf"),
        {"centre_row_col", "finite number"}},
       {"size_negative",
        with(good, size, "image_size: [-1024, 768]"),
        {"infrared.left.model.image_size", "1..16384"}},
       {"size_zero", with(good, size, "image_size: [1024, 0]"), {"image_size", "1..16384"}},
       {"size_huge", with(good, size, "image_size: [1e30, 768]"), {"image_size", "1..16384"}},
       {"size_fraction", with(good, size, "image_size: [1024.5, 768]"), {"image_size"}},
       {"size_one_number",
        with(good, size, "image_size: [1024]"),
        {"image_size", "expected 2 numbers, found 1"}},
       {"bit_depth_text",
        with(good, "bit_depth: 14", "bit_depth: fourteen"),
        {"bit_depth", "expected an integer"}},
       {"pitch_negative",
        with(good, "pixel_pitch_um: 14", "pixel_pitch_um: -14"),
        {"pixel_pitch_um: must be positive"}},
       {"not_a_rotation",
        with(good, "R: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]", "R: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]"),
        {"R is not a rotation"}},
       {"notes_a_map", "name: x\nreference: a\nnotes: {a: b}\n", {"notes: expected a list"}},
       {"camera_name_a_list",
        with(good, "  infrared.right:\n", "  [infrared.right]:\n"),
        {"a key must be a plain name"}},
       {"unknown_reference",
        with(good, "reference: visible.left", "reference: visible.middle"),
        {"no camera named 'visible.middle'"}}});
}

TEST(BadFiles, Scene) {
  const std::string good = read(thermovis::test::source_root() / "deploy/scenes/paper.yaml");
  expect_errors<ConfigError>(
      "scene", [](const fs::path& p) { rt::load_scene(p); },
      {{"empty", "", {"empty scene file"}},
       {"not_yaml", "targets: [{id: a", {"YAML syntax"}},
       {"a_list", "- a\n", {"scene: expected a map"}},
       {"missing_name", with(good, "name: paper\n", ""), {"missing key 'name'"}},
       {"distance_text",
        with(good, "distance_m: 5,", "distance_m: five,"),
        {"target 'person_05m'.distance_m", "finite number"}},
       {"distance_nan",
        with(good, "distance_m: 5,", "distance_m: .nan,"),
        {"distance_m", "finite number"}},
       {"height_inf",
        with(good, "camera_height_m: 1.4", "camera_height_m: -.inf"),
        {"camera_height_m", "finite number"}},
       {"distance_negative",
        with(good, "distance_m: 5,", "distance_m: -5,"),
        {"distance_m: must be positive"}},
       {"frame_rate_zero",
        with(good, "frame_rate_hz: 50", "frame_rate_hz: 0"),
        {"frame_rate_hz: must be positive"}},
       {"targets_a_map", "name: s\ntargets: {a: 1}\n", {"targets: expected a list"}},
       {"texture_name_a_list",
        with(good, "name: paper\n", "name: paper\ntextures: {[a]: {}}\n"),
        {"a key must be a plain name"}},
       {"behind", with(good, "bearing_deg: 20,", "bearing_deg: 120,"), {"behind the camera"}}});
}

const std::string kCameraYaml =
    "model:\n"
    "  type: taylor\n"
    "  image_size: [1024, 768]\n"
    "  centre_row_col: [382.9, 514.4]\n"
    "  affine_cde: [0.9978, 0.000225, 0.000225]\n"
    "  pol: [-131.9168515, 0, 0.001906964285, -1.273626573e-07, -1.823281082e-10]\n";

TEST(BadFiles, CameraCalibrationYaml) {
  ASSERT_NO_THROW(rt::parse_taylor_yaml(kCameraYaml, "camera.yaml"));
  const std::string& good = kCameraYaml;
  expect_errors<ConfigError>(
      "camera", [](const fs::path& p) { rt::load_taylor_yaml(p); },
      {{"empty", "", {"expected a camera model map"}},
       {"not_yaml", "model: {type: [", {"YAML syntax"}},
       {"unknown_model", with(good, "type: taylor", "type: pinhole"), {"unknown model 'pinhole'"}},
       {"missing_centre",
        with(good, "  centre_row_col: [382.9, 514.4]\n", ""),
        {"missing key 'centre_row_col'"}},
       {"pol_scalar",
        with(good,
             "pol: [-131.9168515, 0, 0.001906964285, -1.273626573e-07, "
             "-1.823281082e-10]",
             "pol: -131.9"),
        {"model.pol: expected a list"}},
       {"affine_nan",
        with(good, "affine_cde: [0.9978", "affine_cde: [.nan"),
        {"affine_cde", "finite number"}},
       {"a0_positive",
        with(good, "pol: [-131.9168515", "pol: [131.9168515"),
        {"a0 must be negative"}},
       {"singular_affine",
        with(good, "affine_cde: [0.9978, 0.000225, 0.000225]", "affine_cde: [0, 1, 0]"),
        {"singular"}},
       {"size_zero",
        with(good, "image_size: [1024, 768]", "image_size: [0, 768]"),
        {"image_size", "1..16384"}},
       {"size_huge",
        with(good, "image_size: [1024, 768]", "image_size: [1024, 1e300]"),
        {"image_size", "1..16384"}}});
}

const std::string kOcamText =
    "#polynomial coefficients for the DIRECT mapping function\n\n"
    "5 -131.9168515 0 0.001906964285 -1.273626573e-07 -1.823281082e-10\n\n"
    "#polynomial coefficients for the inverse mapping function\n\n"
    "3 266.3 273.2 147.99\n\n"
    "#center: \"row\" and \"column\", starting from 0 (C convention)\n\n"
    "382.8750254 514.3690835\n\n"
    "#affine parameters \"c\", \"d\", \"e\"\n\n"
    "0.9977992097 0.0002249579245 0.0002249579245\n\n"
    "#image size: \"height\" and \"width\"\n\n"
    "768 1024\n";

TEST(BadFiles, OcamCalibResults) {
  std::istringstream in(kOcamText);
  ASSERT_NO_THROW(thermovis::camera::parse_ocam_calib_results(in, "calib_results.txt"));
  const std::string& good = kOcamText;
  expect_errors<std::runtime_error>(
      "ocam", [](const fs::path& p) { thermovis::camera::read_ocam_calib_results(p); },
      {{"empty", "", {"expected 5 blocks", "found 0"}},
       {"yaml_instead", kCameraYaml, {"polynomial", "is not a number"}},
       {"word_in_pol",
        with(good, "5 -131.9168515", "5 minus131.9"),
        {"polynomial", "not a number"}},
       {"count_wrong",
        with(good, "5 -131.9168515", "6 -131.9168515"),
        {"polynomial: count 6", "5 coefficients"}},
       {"count_negative",
        with(good, "5 -131.9168515", "-5130 -131.9168515"),
        {"polynomial: count -5130"}},
       {"count_nan", with(good, "3 266.3", "nan 266.3"), {"inverse polynomial: count nan"}},
       {"pol_inf", with(good, "5 -131.9168515", "5 -inf"), {"not finite"}},
       {"centre_missing",
        with(good, "382.8750254 514.3690835", "382.8750254"),
        {"centre: expected 'row column'"}},
       {"size_negative", with(good, "768 1024", "-768 1024"), {"image size: height", "1..16384"}},
       {"size_huge", with(good, "768 1024", "768 1e300"), {"image size: width", "1..16384"}},
       {"size_fraction", with(good, "768 1024", "768.5 1024"), {"image size: height"}}});
}

}  // namespace
