#include "thermovis/runtime/scene_io.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <stdexcept>

#include "thermovis/runtime/yaml_util.hpp"

namespace thermovis::runtime {
namespace {

using sim::Scene;
using sim::Texture;

struct Reader {
  const std::string& src;

  double number(const YAML::Node& node, const std::string& ctx) const {
    return as_double(src, node, ctx);
  }
  double positive(const YAML::Node& node, const std::string& ctx) const {
    const double v = as_double(src, node, ctx);
    if (!(v > 0.0)) throw ConfigError(where(src, node) + ": " + ctx + ": must be positive");
    return v;
  }
  double non_negative(const YAML::Node& node, const std::string& ctx) const {
    const double v = as_double(src, node, ctx);
    if (v < 0.0) throw ConfigError(where(src, node) + ": " + ctx + ": must not be negative");
    return v;
  }
  // Optional keys: the struct's default stays when the key is absent.
  void opt_number(const YAML::Node& map, const char* key, const std::string& ctx,
                  double& value) const {
    if (map[key]) value = number(map[key], ctx + "." + key);
  }
  void opt_positive(const YAML::Node& map, const char* key, const std::string& ctx,
                    double& value) const {
    if (map[key]) value = positive(map[key], ctx + "." + key);
  }
  void opt_non_negative(const YAML::Node& map, const char* key, const std::string& ctx,
                        double& value) const {
    if (map[key]) value = non_negative(map[key], ctx + "." + key);
  }
  // [r, g, b] reflectances in [0, max] -> B, G, R.
  Eigen::Vector3d colour(const YAML::Node& node, const std::string& ctx, double max) const {
    const auto rgb = as_doubles(src, node, ctx, 3);
    for (double v : rgb) {
      if (v < 0.0 || v > max)
        throw ConfigError(where(src, node) + ": " + ctx + ": each value must be in [0, " +
                          std::to_string(static_cast<int>(max)) + "]");
    }
    return {rgb[2], rgb[1], rgb[0]};
  }
  Eigen::Vector2d pair(const YAML::Node& node, const std::string& ctx) const {
    const auto v = as_doubles(src, node, ctx, 2);
    return {v[0], v[1]};
  }
  // A texture name that must exist in the scene (built in or defined under textures:).
  std::string texture(const Scene& scene, const YAML::Node& node, const std::string& ctx) const {
    const std::string name = as_string(src, node, ctx);
    if (scene.texture_index(name) < 0) {
      std::string known;
      for (const Texture& t : scene.textures) known += (known.empty() ? "" : ", ") + t.name;
      throw ConfigError(where(src, node) + ": " + ctx + ": unknown texture '" + name +
                        "' (known: " + known + ")");
    }
    return name;
  }
};

sim::TexturePattern pattern_from(const Reader& r, const YAML::Node& node, const std::string& ctx) {
  const std::string name = as_string(r.src, node, ctx);
  using P = sim::TexturePattern;
  for (const auto& [key, value] :
       {std::pair{"uniform", P::uniform}, std::pair{"noise", P::noise},
        std::pair{"stripes", P::stripes}, std::pair{"checker", P::checker},
        std::pair{"brick", P::brick}, std::pair{"foliage", P::foliage}}) {
    if (name == key) return value;
  }
  throw ConfigError(where(r.src, node) + ": " + ctx + ": unknown pattern '" + name +
                    "' (known: uniform, noise, stripes, checker, brick, foliage)");
}

void read_texture(const Reader& r, const std::string& name, const YAML::Node& node, Scene& scene) {
  const std::string ctx = "textures." + name;
  check_keys(r.src, node, ctx,
             {"pattern", "colour_rgb", "colour2_rgb", "scale_m", "contrast", "temperature_c",
              "temperature_offset_k", "temperature_contrast_k"});
  Texture t;
  t.name = name;
  t.pattern = pattern_from(r, require(r.src, node, ctx, "pattern"), ctx + ".pattern");
  t.colour = r.colour(require(r.src, node, ctx, "colour_rgb"), ctx + ".colour_rgb", 1.0);
  t.colour2 =
      node["colour2_rgb"] ? r.colour(node["colour2_rgb"], ctx + ".colour2_rgb", 1.0) : t.colour;
  r.opt_positive(node, "scale_m", ctx, t.scale_m);
  r.opt_non_negative(node, "contrast", ctx, t.contrast);
  if (t.contrast > 1.0)
    throw ConfigError(where(r.src, node["contrast"]) + ": " + ctx + ".contrast: must be <= 1");
  if (node["temperature_c"])
    t.temperature_c = r.number(node["temperature_c"], ctx + ".temperature_c");
  r.opt_number(node, "temperature_offset_k", ctx, t.temperature_offset_k);
  r.opt_non_negative(node, "temperature_contrast_k", ctx, t.temperature_contrast_k);
  const int existing = scene.texture_index(name);
  if (existing >= 0) {
    scene.textures[static_cast<std::size_t>(existing)] = t;  // redefines a built-in one
  } else {
    scene.textures.push_back(t);
  }
}

sim::Target read_target(const Reader& r, const YAML::Node& node, std::size_t index,
                        const Scene& scene) {
  std::string ctx = "targets[" + std::to_string(index) + "]";
  check_keys(r.src, node, ctx,
             {"id", "class", "distance_m", "bearing_deg", "elevation_m", "heading_deg", "height_m",
              "width_m", "length_m", "velocity_mps", "texture"});
  sim::Target t;
  t.id = as_string(r.src, require(r.src, node, ctx, "id"), ctx + ".id");
  if (t.id.empty()) throw ConfigError(where(r.src, node["id"]) + ": " + ctx + ".id: empty");
  ctx = "target '" + t.id + "'";
  const YAML::Node cls = require(r.src, node, ctx, "class");
  try {
    t.cls = sim::target_class_from_string(as_string(r.src, cls, ctx + ".class"));
  } catch (const std::invalid_argument& e) {
    throw ConfigError(where(r.src, cls) + ": " + ctx + ".class: " + e.what());
  }
  t.distance_m = r.positive(require(r.src, node, ctx, "distance_m"), ctx + ".distance_m");
  r.opt_number(node, "bearing_deg", ctx, t.bearing_deg);
  if (!(std::abs(t.bearing_deg) < 90.0)) {
    throw ConfigError(where(r.src, node["bearing_deg"]) + ": " + ctx +
                      ".bearing_deg: the target is behind the camera (bearing must be within "
                      "-90 .. 90 deg, 0 = straight ahead)");
  }
  r.opt_non_negative(node, "elevation_m", ctx, t.elevation_m);
  r.opt_number(node, "heading_deg", ctx, t.heading_deg);
  r.opt_positive(node, "height_m", ctx, t.height_m);
  r.opt_positive(node, "width_m", ctx, t.width_m);
  r.opt_positive(node, "length_m", ctx, t.length_m);
  if (node["velocity_mps"]) t.velocity_mps = r.pair(node["velocity_mps"], ctx + ".velocity_mps");
  if (node["texture"]) t.texture = r.texture(scene, node["texture"], ctx + ".texture");
  return t;
}

}  // namespace

Scene parse_scene(const std::string& yaml_text, const std::string& src) {
  const YAML::Node root = parse_yaml(yaml_text, src);
  if (!root || root.IsNull()) throw ConfigError(src + ": empty scene file");
  check_keys(src, root, "scene",
             {"name", "description", "camera_height_m", "frame_rate_hz", "visible", "infrared",
              "ground", "textures", "walls", "targets"});
  const Reader r{src};
  Scene scene;
  scene.name = as_string(src, require(src, root, "scene", "name"), "name");
  if (root["description"]) scene.description = as_string(src, root["description"], "description");
  r.opt_positive(root, "camera_height_m", "scene", scene.camera_height_m);
  r.opt_positive(root, "frame_rate_hz", "scene", scene.frame_rate_hz);

  if (const YAML::Node textures = root["textures"]) {
    if (!textures.IsMap()) throw ConfigError(where(src, textures) + ": textures: expected a map");
    for (const auto& item : textures)
      read_texture(r, as_key(src, item.first, "textures"), item.second, scene);
  }
  if (const YAML::Node v = root["visible"]) {
    check_keys(src, v, "visible",
               {"illuminance_lux", "electrons_per_lux", "full_well_e", "read_noise_e", "max_gain",
                "blur_sigma_px", "sky_colour_rgb"});
    sim::VisibleBand& b = scene.visible;
    r.opt_non_negative(v, "illuminance_lux", "visible", b.illuminance_lux);
    r.opt_positive(v, "electrons_per_lux", "visible", b.electrons_per_lux);
    r.opt_positive(v, "full_well_e", "visible", b.full_well_e);
    r.opt_non_negative(v, "read_noise_e", "visible", b.read_noise_e);
    r.opt_positive(v, "max_gain", "visible", b.max_gain);
    if (b.max_gain < 1.0)
      throw ConfigError(where(src, v["max_gain"]) + ": visible.max_gain: must be >= 1");
    r.opt_non_negative(v, "blur_sigma_px", "visible", b.blur_sigma_px);
    if (v["sky_colour_rgb"])
      b.sky_colour = r.colour(v["sky_colour_rgb"], "visible.sky_colour_rgb", 2.0);
  }
  if (const YAML::Node ir = root["infrared"]) {
    check_keys(src, ir, "infrared",
               {"ambient_c", "sky_c", "netd_k", "counts_per_k", "counts_at_20c",
                "fpn_offset_counts", "fpn_column_counts", "fpn_gain"});
    sim::InfraredBand& b = scene.infrared;
    r.opt_number(ir, "ambient_c", "infrared", b.ambient_c);
    r.opt_number(ir, "sky_c", "infrared", b.sky_c);
    r.opt_non_negative(ir, "netd_k", "infrared", b.netd_k);
    r.opt_positive(ir, "counts_per_k", "infrared", b.counts_per_k);
    r.opt_non_negative(ir, "counts_at_20c", "infrared", b.counts_at_20c);
    r.opt_non_negative(ir, "fpn_offset_counts", "infrared", b.fpn_offset_counts);
    r.opt_non_negative(ir, "fpn_column_counts", "infrared", b.fpn_column_counts);
    r.opt_non_negative(ir, "fpn_gain", "infrared", b.fpn_gain);
  }
  if (const YAML::Node g = root["ground"]) {
    check_keys(
        src, g, "ground",
        {"road_texture", "verge_texture", "road_centre_x_m", "road_half_width_m", "centre_line"});
    if (g["road_texture"])
      scene.ground.road_texture = r.texture(scene, g["road_texture"], "ground.road_texture");
    if (g["verge_texture"])
      scene.ground.verge_texture = r.texture(scene, g["verge_texture"], "ground.verge_texture");
    r.opt_number(g, "road_centre_x_m", "ground", scene.ground.road_centre_x_m);
    r.opt_non_negative(g, "road_half_width_m", "ground", scene.ground.road_half_width_m);
    if (g["centre_line"])
      scene.ground.centre_line = as_bool(src, g["centre_line"], "ground.centre_line");
  }
  if (const YAML::Node walls = root["walls"]) {
    if (!walls.IsSequence()) throw ConfigError(where(src, walls) + ": walls: expected a list");
    for (std::size_t i = 0; i < walls.size(); ++i) {
      const YAML::Node w = walls[i];
      const std::string ctx = "walls[" + std::to_string(i) + "]";
      check_keys(src, w, ctx, {"from_xz_m", "to_xz_m", "height_m", "texture"});
      sim::Wall wall;
      wall.from = r.pair(require(src, w, ctx, "from_xz_m"), ctx + ".from_xz_m");
      wall.to = r.pair(require(src, w, ctx, "to_xz_m"), ctx + ".to_xz_m");
      if ((wall.to - wall.from).norm() <= 0.0)
        throw ConfigError(where(src, w) + ": " + ctx + ": from_xz_m and to_xz_m are the same");
      r.opt_positive(w, "height_m", ctx, wall.height_m);
      if (w["texture"]) wall.texture = r.texture(scene, w["texture"], ctx + ".texture");
      scene.walls.push_back(wall);
    }
  }
  if (const YAML::Node targets = root["targets"]) {
    if (!targets.IsSequence())
      throw ConfigError(where(src, targets) + ": targets: expected a list");
    for (std::size_t i = 0; i < targets.size(); ++i) {
      sim::Target t = read_target(r, targets[i], i, scene);
      for (const sim::Target& other : scene.targets) {
        if (other.id == t.id)
          throw ConfigError(where(src, targets[i]["id"]) + ": targets: duplicate id '" + t.id +
                            "'");
      }
      scene.targets.push_back(std::move(t));
    }
  }
  try {
    sim::validate(scene);
  } catch (const std::invalid_argument& e) {
    throw ConfigError(src + ": " + e.what());
  }
  return scene;
}

Scene load_scene(const std::filesystem::path& path) {
  return parse_scene(read_text_file(path.string(), "scene file"), path.string());
}

std::filesystem::path shipped_scene_path(const std::string& name) {
  const std::string file = name + ".yaml";
  std::vector<std::filesystem::path> candidates;
  if (const char* env = std::getenv("THERMOVIS_SCENES"); env != nullptr && *env != '\0')
    candidates.emplace_back(std::filesystem::path(env) / file);
  candidates.emplace_back(std::filesystem::path(THERMOVIS_SOURCE_DIR) / "deploy/scenes" / file);
  candidates.emplace_back(std::filesystem::path("/usr/local/share/thermovis/scenes") / file);
  for (const auto& candidate : candidates) {
    if (std::filesystem::exists(candidate)) return candidate;
  }
  throw ConfigError("no shipped scene '" + name + "' (looked in $THERMOVIS_SCENES, " +
                    candidates[candidates.size() - 2].parent_path().string() + ")");
}

std::filesystem::path scene_argument_path(const std::string& arg) {
  namespace fs = std::filesystem;
  if (fs::exists(arg) || arg.find('/') != std::string::npos || fs::path(arg).has_extension())
    return arg;
  return shipped_scene_path(arg);
}

}  // namespace thermovis::runtime
