#pragma once
// A 3-D scene for the simulated dual-band rig: ground, walls, sky and targets with surface
// textures (visible reflectance and infrared temperature), lighting and sensor settings.
//
// World frame: the rig frame (camera/rig.hpp: the reference camera's frame), x right, y down,
// z forward, metres. The rig is taken as level: gravity is +y and the ground is the plane
// y = camera_height_m. Ground coordinates (x, z) are "right" and "forward" of the reference
// camera. A target is placed by the horizontal distance and bearing of its foot point (bearing
// positive to the right, 0 = straight ahead).
//
// The scene YAML (common/runtime scene_io.hpp, deploy/scenes/README.md) fills these structs;
// every default below is the one the YAML falls back to.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace thermovis::sim {

// How a texture modulates its colours over the surface coordinates (u, v) in metres.
enum class TexturePattern {
  uniform,  // colour, no modulation, not shaded: self-luminous (markers, lamps)
  noise,    // colour times fractal value noise of cell scale_m
  stripes,  // bands of colour / colour2, scale_m wide, along u
  checker,  // squares of scale_m in colour / colour2
  brick,    // bricks scale_m long (scale_m / 3 high) in colour, mortar lines in colour2
  foliage,  // blotches of colour / colour2 (leaves), scale_m across
};

struct Texture {
  std::string name;
  TexturePattern pattern = TexturePattern::noise;
  Eigen::Vector3d colour{0.5, 0.5, 0.5};   // diffuse reflectance, B, G, R, each in [0, 1]
  Eigen::Vector3d colour2{0.2, 0.2, 0.2};  // second colour of two-colour patterns
  double scale_m = 0.1;                    // size of the pattern's cells, m
  double contrast = 0.3;                   // relative amplitude of the fine grain, [0, 1]
  // Mean surface temperature: absolute when set, else the scene's ambient plus the offset.
  std::optional<double> temperature_c;
  double temperature_offset_k = 0.0;
  double temperature_contrast_k = 0.5;  // amplitude of the temperature pattern, K
};

// The textures every scene may use by name (asphalt, grass, brick, concrete, foliage, clothing,
// clothing_red, clothing_blue, trousers, skin, car_paint, glass, tyre, metal, road_marking,
// marker). A scene may add its own or redefine these.
std::vector<Texture> builtin_textures();

enum class TargetClass { person, car, pole, marker };
const char* to_string(TargetClass cls);
// Throws std::invalid_argument for an unknown name.
TargetClass target_class_from_string(const std::string& name);

// Target shapes (local frame: origin at the foot point on the ground, x right, y down, z forward
// before the heading turns it):
//  person: legs, torso (elliptic cylinders width x depth), neck and head (sphere); height
//          1.75 m, width 0.5 m, depth 0.3 m by default; textures: `texture` (clothing), legs
//          "trousers", head and neck "skin";
//  car:    body box (texture), cabin box ("glass"), underbody ("tyre"); length along z 4.5 m,
//          width 1.8 m, height 1.5 m;
//  pole:   a cylinder, height 4 m, width (diameter) 0.2 m;
//  marker: a sphere of diameter `width` (0.1 m), for geometry checks.
struct Target {
  std::string id;
  TargetClass cls = TargetClass::person;
  double distance_m = 10.0;  // horizontal distance of the foot point at t = 0, m
  double bearing_deg = 0.0;  // bearing of the foot point, deg, positive to the right
  double elevation_m = 0.0;  // foot point above the ground, m
  double heading_deg = 0.0;  // rotation about the vertical, deg (car: 0 = driving along +z)
  double height_m = 0.0;     // 0 = class default
  double width_m = 0.0;      // 0 = class default
  double length_m = 0.0;     // depth along local z; 0 = class default
  Eigen::Vector2d velocity_mps{0.0, 0.0};  // on the ground: (x right, z forward), m/s
  std::string texture;                     // main surface; empty = class default
  bool moving() const { return velocity_mps.squaredNorm() > 0.0; }
};

struct Wall {
  Eigen::Vector2d from{0.0, 0.0}, to{0.0, 0.0};  // ground points (x, z), m
  double height_m = 3.0;
  std::string texture = "brick";
};

struct Ground {
  std::string road_texture = "asphalt";
  std::string verge_texture = "grass";
  double road_centre_x_m = 0.0;    // x of the road's centre line, m
  double road_half_width_m = 3.5;  // m; 0 = no road
  bool centre_line = true;         // dashed road_marking line along z at the centre
};

// Visible band: illumination and the sensor's exposure, gain and noise.
// White (reflectance 1) collects min(illuminance * electrons_per_lux, 0.8 full well) electrons;
// the gain lifts that to 0.8 of full scale up to max_gain; shot and read noise follow.
struct VisibleBand {
  double illuminance_lux = 10000.0;  // day 10000+, overcast 1000, dusk 10, night 0.05
  double electrons_per_lux = 400.0;  // electrons a white surface collects per lux, e-
  double full_well_e = 10000.0;
  double read_noise_e = 5.0;
  double max_gain = 16.0;
  double blur_sigma_px = 0.0;                   // Gaussian optical blur, px (0 = none)
  Eigen::Vector3d sky_colour{0.95, 0.8, 0.65};  // sky brightness relative to white, B, G, R
};

// Infrared band: surface temperatures map to in-band (8-14 um) radiance, then to raw counts:
// counts = counts_at_20c + counts_per_k * (L(T) - L(20 C)) / L'(20 C), 14 bits used.
struct InfraredBand {
  double ambient_c = 15.0;  // air temperature; textures without temperature_c follow it
  double sky_c = -20.0;     // apparent sky temperature (clear sky is cold)
  double netd_k = 0.05;     // temporal noise, K (NETD)
  double counts_per_k = 50.0;
  double counts_at_20c = 8000.0;
  double fpn_offset_counts = 20.0;  // per-pixel offset non-uniformity, counts (1 sigma)
  double fpn_column_counts = 8.0;   // per-column offset, counts (1 sigma)
  double fpn_gain = 0.01;           // per-pixel gain non-uniformity (1 sigma, relative)
};

struct Scene {
  std::string name;
  std::string description;
  double camera_height_m = 1.4;  // reference camera above the ground
  double frame_rate_hz = 50.0;   // frame k is at t = k / frame_rate_hz
  Ground ground;
  std::vector<Wall> walls;
  std::vector<Target> targets;
  std::vector<Texture> textures = builtin_textures();
  VisibleBand visible;
  InfraredBand infrared;

  // Index of a texture by name, or -1.
  int texture_index(const std::string& texture_name) const;
};

// Checks sizes, ranges, texture names and that targets are in front of the rig; throws
// std::invalid_argument naming the bad item.
void validate(const Scene& scene);

// Class defaults applied: the target's height, width, length and main texture.
Target with_class_defaults(const Target& target);

// Foot point of a target at time t (s) in the world frame, m.
Eigen::Vector3d foot_position(const Scene& scene, const Target& target, double t_s);
// Centre of the target's bounding box at time t (s) in the world frame, m: the point whose
// distance the truth reports.
Eigen::Vector3d centre_position(const Scene& scene, const Target& target, double t_s);

}  // namespace thermovis::sim
