// Scene YAML: the shipped scenes parse, and broken files fail with the line and the key.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"
#include "thermovis/test/data.hpp"

namespace {

using thermovis::runtime::ConfigError;
using thermovis::runtime::parse_scene;

const char* kValidScene = R"(name: t
targets:
  - {id: a, class: person, distance_m: 10, bearing_deg: 5}
)";

// The message of the ConfigError that parsing `text` throws ("" if none).
std::string error_of(const std::string& text) {
  try {
    parse_scene(text, "s.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(SceneIo, ShippedScenesParse) {
  for (const char* name : {"paper", "night", "street", "obstacles"}) {
    SCOPED_TRACE(name);
    const auto scene = thermovis::runtime::load_scene(
        thermovis::test::source_root() / "deploy/scenes" / (std::string(name) + ".yaml"));
    EXPECT_EQ(scene.name, name);
    EXPECT_FALSE(scene.targets.empty());
  }
}

TEST(SceneIo, PaperSceneHasAPersonAtEveryTable6Distance) {
  const auto scene =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("paper"));
  std::multiset<double> distances;
  for (const auto& t : scene.targets) {
    if (t.cls == thermovis::sim::TargetClass::person) distances.insert(t.distance_m);
    EXPECT_FALSE(t.moving()) << t.id;
  }
  EXPECT_EQ(distances, (std::multiset<double>{5, 10, 15, 20, 25, 30, 40, 60}));
}

TEST(SceneIo, NightSceneIsDarkAndColdAroundWarmPeople) {
  const auto night =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("night"));
  EXPECT_LT(night.visible.illuminance_lux, 0.1);
  EXPECT_LT(night.infrared.ambient_c, 10.0);
}

TEST(SceneIo, ValidSceneReadsValuesAndDefaults) {
  const auto scene = parse_scene(std::string(kValidScene) + R"(visible: {illuminance_lux: 3}
infrared: {ambient_c: 7}
textures:
  spots: {pattern: checker, colour_rgb: [1, 0, 0], scale_m: 0.2, temperature_c: 40}
walls:
  - {from_xz_m: [-5, 10], to_xz_m: [-5, 50], texture: spots}
)",
                                 "s.yaml");
  EXPECT_DOUBLE_EQ(scene.visible.illuminance_lux, 3.0);
  EXPECT_DOUBLE_EQ(scene.infrared.ambient_c, 7.0);
  EXPECT_DOUBLE_EQ(scene.camera_height_m, 1.4);  // default
  ASSERT_EQ(scene.walls.size(), 1u);
  EXPECT_DOUBLE_EQ(scene.walls[0].height_m, 3.0);
  const int spots = scene.texture_index("spots");
  ASSERT_GE(spots, 0);
  // colour_rgb [1, 0, 0] is red: the struct stores B, G, R.
  EXPECT_DOUBLE_EQ(scene.textures[static_cast<std::size_t>(spots)].colour.z(), 1.0);
  EXPECT_DOUBLE_EQ(scene.textures[static_cast<std::size_t>(spots)].colour.x(), 0.0);
  EXPECT_DOUBLE_EQ(*scene.textures[static_cast<std::size_t>(spots)].temperature_c, 40.0);
}

TEST(SceneIo, UnknownKeyNamesLineAndKey) {
  const std::string msg = error_of(std::string(kValidScene) + "visible:\n  iluminance_lux: 3\n");
  EXPECT_NE(msg.find("s.yaml:5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("iluminance_lux"), std::string::npos) << msg;
}

TEST(SceneIo, UnknownTargetKeyNamesLine) {
  const std::string msg = error_of(R"(name: t
targets:
  - id: a
    class: person
    distance_m: 10
    colour: red
)");
  EXPECT_NE(msg.find("s.yaml:6"), std::string::npos) << msg;
  EXPECT_NE(msg.find("colour"), std::string::npos) << msg;
}

TEST(SceneIo, NegativeSizesNameTheLine) {
  const std::string msg = error_of(R"(name: t
targets:
  - id: a
    class: car
    distance_m: 10
    width_m: -1.8
)");
  EXPECT_NE(msg.find("s.yaml:6"), std::string::npos) << msg;
  EXPECT_NE(msg.find("width_m"), std::string::npos) << msg;
  EXPECT_NE(msg.find("positive"), std::string::npos) << msg;
  const std::string wall = error_of(R"(name: t
walls:
  - {from_xz_m: [0, 5], to_xz_m: [3, 5], height_m: -2}
)");
  EXPECT_NE(wall.find("s.yaml:3"), std::string::npos) << wall;
  EXPECT_NE(wall.find("height_m"), std::string::npos) << wall;
}

TEST(SceneIo, TargetBehindTheCameraNamesTheLine) {
  const std::string msg = error_of(R"(name: t
targets:
  - id: a
    class: person
    distance_m: 10
    bearing_deg: 135
)");
  EXPECT_NE(msg.find("s.yaml:6"), std::string::npos) << msg;
  EXPECT_NE(msg.find("behind the camera"), std::string::npos) << msg;
}

TEST(SceneIo, MissingTextureNamesTheLineAndTheName) {
  const std::string msg = error_of(R"(name: t
targets:
  - {id: a, class: person, distance_m: 10}
  - {id: b, class: person, distance_m: 12,
     texture: tartan}
)");
  EXPECT_NE(msg.find("s.yaml:5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("unknown texture 'tartan'"), std::string::npos) << msg;
  const std::string ground = error_of("name: t\nground:\n  road_texture: cobbles\n");
  EXPECT_NE(ground.find("s.yaml:3"), std::string::npos) << ground;
  EXPECT_NE(ground.find("cobbles"), std::string::npos) << ground;
}

TEST(SceneIo, OtherMistakesAreClear) {
  EXPECT_NE(
      error_of("name: t\ntargets:\n  - {id: a, class: tree, distance_m: 5}\n").find("s.yaml:3"),
      std::string::npos);
  EXPECT_NE(error_of("name: t\ntargets:\n  - {id: a, class: pole, distance_m: 5}\n  - {id: a, "
                     "class: pole, distance_m: 6}\n")
                .find("duplicate id 'a'"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\ntextures:\n  x: {pattern: plaid, colour_rgb: [1, 1, 1]}\n")
                .find("unknown pattern"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\ntextures:\n  x: {pattern: noise, colour_rgb: [1, 2, 1]}\n")
                .find("s.yaml:3"),
            std::string::npos);
  EXPECT_NE(error_of("name: [t\n").find("YAML syntax"), std::string::npos);
  EXPECT_THROW(thermovis::runtime::load_scene("/nonexistent/scene.yaml"), ConfigError);
}

}  // namespace

// A --scene argument is a shipped scene's name or a path: a name finds deploy/scenes/<name>.yaml,
// anything that looks like a path is kept as given (its errors come when it is read), an
// unknown name is named.
TEST(SceneIo, SceneArgumentIsANameOrAPath) {
  using thermovis::runtime::scene_argument_path;
  EXPECT_EQ(scene_argument_path("street"), thermovis::runtime::shipped_scene_path("street"));
  EXPECT_EQ(scene_argument_path("my/street.yaml"), std::filesystem::path("my/street.yaml"));
  EXPECT_EQ(scene_argument_path("mine.yaml"), std::filesystem::path("mine.yaml"));
  try {
    scene_argument_path("no_such_scene");
    ADD_FAILURE() << "an unknown scene name was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_scene"), std::string::npos) << e.what();
  }
}
