#include "thermovis/sim/scene.hpp"

#include <cmath>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::sim {
namespace {

constexpr util::EnumName<TargetClass> kTargetClassNames[] = {{TargetClass::person, "person"},
                                                             {TargetClass::car, "car"},
                                                             {TargetClass::pole, "pole"},
                                                             {TargetClass::marker, "marker"}};

constexpr double kPi = 3.14159265358979323846;

Texture make_texture(const std::string& name, TexturePattern pattern, Eigen::Vector3d colour,
                     Eigen::Vector3d colour2, double scale_m, double contrast,
                     std::optional<double> temperature_c, double temperature_offset_k,
                     double temperature_contrast_k) {
  Texture t;
  t.name = name;
  t.pattern = pattern;
  t.colour = colour;
  t.colour2 = colour2;
  t.scale_m = scale_m;
  t.contrast = contrast;
  t.temperature_c = temperature_c;
  t.temperature_offset_k = temperature_offset_k;
  t.temperature_contrast_k = temperature_contrast_k;
  return t;
}

void require_positive(double value, const std::string& what) {
  if (!(value > 0.0) || !std::isfinite(value))
    throw std::invalid_argument(what + " must be positive (is " + std::to_string(value) + ")");
}

void require_non_negative(double value, const std::string& what) {
  if (!(value >= 0.0) || !std::isfinite(value))
    throw std::invalid_argument(what + " must not be negative (is " + std::to_string(value) + ")");
}

}  // namespace

std::vector<Texture> builtin_textures() {
  using P = TexturePattern;
  using V = Eigen::Vector3d;
  const std::optional<double> ambient;  // follows the scene's ambient temperature
  // Reflectances are B, G, R; temperatures are typical daytime surface values.
  return {
      make_texture("asphalt", P::noise, V(0.22, 0.22, 0.23), V(0.12, 0.12, 0.13), 0.05, 0.45,
                   ambient, 3.0, 0.6),
      make_texture("grass", P::foliage, V(0.12, 0.40, 0.22), V(0.05, 0.20, 0.10), 0.12, 0.3,
                   ambient, -1.0, 0.8),
      make_texture("brick", P::brick, V(0.18, 0.28, 0.55), V(0.60, 0.62, 0.65), 0.25, 0.25, ambient,
                   1.0, 0.5),
      make_texture("concrete", P::noise, V(0.50, 0.52, 0.53), V(0.35, 0.36, 0.37), 0.3, 0.3,
                   ambient, 0.5, 0.5),
      make_texture("foliage", P::foliage, V(0.10, 0.35, 0.15), V(0.04, 0.15, 0.06), 0.3, 0.35,
                   ambient, -2.0, 1.0),
      make_texture("clothing", P::stripes, V(0.60, 0.35, 0.20), V(0.85, 0.85, 0.85), 0.08, 0.25,
                   30.0, 0.0, 1.5),
      make_texture("clothing_red", P::checker, V(0.15, 0.15, 0.60), V(0.10, 0.10, 0.20), 0.1, 0.25,
                   29.0, 0.0, 1.5),
      make_texture("clothing_blue", P::noise, V(0.50, 0.25, 0.10), V(0.25, 0.12, 0.05), 0.05, 0.4,
                   30.0, 0.0, 1.2),
      make_texture("trousers", P::noise, V(0.35, 0.22, 0.15), V(0.15, 0.10, 0.07), 0.04, 0.3, 28.0,
                   0.0, 1.0),
      make_texture("skin", P::noise, V(0.45, 0.55, 0.75), V(0.30, 0.38, 0.55), 0.02, 0.15, 34.0,
                   0.0, 0.8),
      make_texture("car_paint", P::noise, V(0.10, 0.10, 0.55), V(0.05, 0.05, 0.30), 0.3, 0.15,
                   ambient, 8.0, 3.0),
      make_texture("glass", P::noise, V(0.12, 0.10, 0.08), V(0.20, 0.18, 0.15), 0.5, 0.1, ambient,
                   -3.0, 0.5),
      make_texture("tyre", P::noise, V(0.05, 0.05, 0.05), V(0.02, 0.02, 0.02), 0.05, 0.3, ambient,
                   10.0, 2.0),
      make_texture("metal", P::stripes, V(0.60, 0.60, 0.60), V(0.30, 0.30, 0.30), 0.3, 0.15,
                   ambient, 0.0, 0.5),
      make_texture("road_marking", P::noise, V(0.85, 0.85, 0.85), V(0.80, 0.80, 0.80), 0.5, 0.05,
                   ambient, 1.0, 0.2),
      make_texture("marker", P::uniform, V(1.0, 1.0, 1.0), V(1.0, 1.0, 1.0), 1.0, 0.0, 60.0, 0.0,
                   0.0),
  };
}

const char* to_string(TargetClass cls) { return util::name_of(kTargetClassNames, cls, "unknown"); }

TargetClass target_class_from_string(const std::string& name) {
  if (const auto cls = util::parse(kTargetClassNames, name)) return *cls;
  throw std::invalid_argument("unknown target class '" + name +
                              "' (known: " + util::join_names(kTargetClassNames, ", ", ", ") + ")");
}

int Scene::texture_index(const std::string& texture_name) const {
  for (std::size_t i = 0; i < textures.size(); ++i) {
    if (textures[i].name == texture_name) return static_cast<int>(i);
  }
  return -1;
}

Target with_class_defaults(const Target& target) {
  Target t = target;
  struct Defaults {
    double height, width, length;
    const char* texture;
  };
  Defaults d{1.75, 0.5, 0.3, "clothing"};
  switch (t.cls) {
    case TargetClass::person:
      break;
    case TargetClass::car:
      d = {1.5, 1.8, 4.5, "car_paint"};
      break;
    case TargetClass::pole:
      d = {4.0, 0.2, 0.2, "metal"};
      break;
    case TargetClass::marker:
      d = {0.1, 0.1, 0.1, "marker"};
      break;
  }
  if (t.height_m == 0.0) t.height_m = d.height;
  if (t.width_m == 0.0) t.width_m = d.width;
  if (t.length_m == 0.0) t.length_m = d.length;
  if (t.cls == TargetClass::marker || t.cls == TargetClass::pole) {
    // Round shapes: one diameter.
    t.length_m = t.width_m;
    if (t.cls == TargetClass::marker) t.height_m = t.width_m;
  }
  if (t.texture.empty()) t.texture = d.texture;
  return t;
}

void validate(const Scene& scene) {
  require_positive(scene.camera_height_m, "camera_height_m");
  require_positive(scene.frame_rate_hz, "frame_rate_hz");
  const auto need_texture = [&](const std::string& name, const std::string& user) {
    if (scene.texture_index(name) < 0)
      throw std::invalid_argument(user + ": unknown texture '" + name + "'");
  };
  for (const Texture& t : scene.textures) {
    const std::string what = "texture '" + t.name + "'";
    require_positive(t.scale_m, what + " scale_m");
    if (!(t.contrast >= 0.0 && t.contrast <= 1.0))
      throw std::invalid_argument(what + " contrast must be in [0, 1]");
    for (const Eigen::Vector3d& c : {t.colour, t.colour2}) {
      if (!(c.minCoeff() >= 0.0 && c.maxCoeff() <= 1.0))
        throw std::invalid_argument(what + " colours must be reflectances in [0, 1]");
    }
    require_non_negative(t.temperature_contrast_k, what + " temperature_contrast_k");
  }
  need_texture(scene.ground.road_texture, "ground.road_texture");
  need_texture(scene.ground.verge_texture, "ground.verge_texture");
  if (scene.ground.centre_line) need_texture("road_marking", "ground.centre_line");
  require_non_negative(scene.ground.road_half_width_m, "ground.road_half_width_m");
  for (std::size_t i = 0; i < scene.walls.size(); ++i) {
    const Wall& w = scene.walls[i];
    const std::string what = "walls[" + std::to_string(i) + "]";
    require_positive(w.height_m, what + ".height_m");
    if ((w.to - w.from).norm() <= 0.0)
      throw std::invalid_argument(what + ": from and to are the same point");
    need_texture(w.texture, what);
  }
  for (const Target& raw : scene.targets) {
    const Target t = with_class_defaults(raw);
    const std::string what = "target '" + t.id + "'";
    if (t.id.empty()) throw std::invalid_argument("a target has an empty id");
    require_positive(t.distance_m, what + " distance_m");
    require_positive(t.height_m, what + " height_m");
    require_positive(t.width_m, what + " width_m");
    require_positive(t.length_m, what + " length_m");
    require_non_negative(t.elevation_m, what + " elevation_m");
    if (!(std::abs(t.bearing_deg) < 90.0))
      throw std::invalid_argument(what + " is behind the camera (bearing " +
                                  std::to_string(t.bearing_deg) + " deg; must be within +-90)");
    if (!t.velocity_mps.allFinite())
      throw std::invalid_argument(what + " velocity_mps must be finite");
    need_texture(t.texture, what);
  }
  for (std::size_t i = 0; i < scene.targets.size(); ++i) {
    for (std::size_t j = i + 1; j < scene.targets.size(); ++j) {
      if (scene.targets[i].id == scene.targets[j].id)
        throw std::invalid_argument("two targets have the id '" + scene.targets[i].id + "'");
    }
  }
  const VisibleBand& v = scene.visible;
  require_non_negative(v.illuminance_lux, "visible.illuminance_lux");
  require_positive(v.electrons_per_lux, "visible.electrons_per_lux");
  require_positive(v.full_well_e, "visible.full_well_e");
  require_non_negative(v.read_noise_e, "visible.read_noise_e");
  if (!(v.max_gain >= 1.0)) throw std::invalid_argument("visible.max_gain must be >= 1");
  require_non_negative(v.blur_sigma_px, "visible.blur_sigma_px");
  if (!(v.sky_colour.minCoeff() >= 0.0 && v.sky_colour.maxCoeff() <= 2.0))
    throw std::invalid_argument("visible.sky_colour must be in [0, 2]");
  const InfraredBand& ir = scene.infrared;
  if (!(ir.ambient_c > -80.0 && ir.ambient_c < 150.0 && ir.sky_c > -80.0 && ir.sky_c < 150.0))
    throw std::invalid_argument("infrared temperatures must be within -80 .. 150 C");
  require_non_negative(ir.netd_k, "infrared.netd_k");
  require_positive(ir.counts_per_k, "infrared.counts_per_k");
  require_non_negative(ir.counts_at_20c, "infrared.counts_at_20c");
  require_non_negative(ir.fpn_offset_counts, "infrared.fpn_offset_counts");
  require_non_negative(ir.fpn_column_counts, "infrared.fpn_column_counts");
  require_non_negative(ir.fpn_gain, "infrared.fpn_gain");
}

Eigen::Vector3d foot_position(const Scene& scene, const Target& target, double t_s) {
  const double bearing = target.bearing_deg * kPi / 180.0;
  const double x = target.distance_m * std::sin(bearing) + target.velocity_mps.x() * t_s;
  const double z = target.distance_m * std::cos(bearing) + target.velocity_mps.y() * t_s;
  return {x, scene.camera_height_m - target.elevation_m, z};
}

Eigen::Vector3d centre_position(const Scene& scene, const Target& target, double t_s) {
  const Target t = with_class_defaults(target);
  return foot_position(scene, t, t_s) - Eigen::Vector3d(0.0, 0.5 * t.height_m, 0.0);
}

}  // namespace thermovis::sim
