#pragma once
// Internal: the scene compiled for ray tracing (ground, walls, targets as primitives), the
// procedural textures and the two bands' radiometry. World frame and units as in scene.hpp.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "thermovis/sim/scene.hpp"

namespace thermovis::sim::detail {

// Ids of what a ray hits, for anti-aliasing edges (a pixel whose 4-neighbours see another id is
// supersampled).
inline constexpr std::uint16_t kSkyId = 0;
inline constexpr std::uint16_t kGroundId = 1;
inline constexpr std::uint16_t kFirstWallId = 2;
inline constexpr std::uint16_t kFirstTargetId = 1000;
inline constexpr std::uint16_t kNoRayId = 0xFFFF;

// What a surface point looks like in both bands.
struct SurfaceSample {
  Eigen::Vector3f reflectance_bgr = Eigen::Vector3f::Zero();  // [0, 1]
  float temperature_c = 0.0f;
};

class TextureSampler {
 public:
  TextureSampler(const Texture& texture, double ambient_c);
  // (u, v): surface coordinates, m. footprint_m: a pixel's size on the surface, m; pattern
  // detail finer than about two footprints fades to its mean (no aliasing shimmer).
  SurfaceSample sample(double u, double v, double footprint_m) const;

 private:
  Texture texture_;
  double mean_temperature_c_;
  std::uint32_t seed_;  // from the texture's name: the scene, not the render seed
};

// Shapes in a target's local frame (origin at the foot point, x right, y down, z forward).
struct Primitive {
  enum class Kind { box, cylinder, sphere };
  Kind kind = Kind::box;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  // box: half extents; cylinder (vertical axis): (radius x, half height, radius z);
  // sphere: radius in x.
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
  int texture = 0;
  // Squared radius of a sphere about `centre` that holds the primitive, with a margin: a ray
  // that passes outside it cannot hit the primitive (a cheap test before the exact one).
  double bound_radius2 = std::numeric_limits<double>::infinity();
};

struct Hit {
  double t = std::numeric_limits<double>::infinity();  // distance along the unit ray, m
  std::uint16_t id = kSkyId;
  int texture = -1;
  double u = 0.0, v = 0.0;                            // surface coordinates, m
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  // world frame, facing the ray
};

struct CompiledTarget {
  Target spec;  // with class defaults
  std::uint16_t id = kFirstTargetId;
  std::vector<Primitive> parts;
  Eigen::Matrix3d R_world_local = Eigen::Matrix3d::Identity();  // heading about +y
  Eigen::Vector3d bound_lo, bound_hi;                           // local bounding box
  std::vector<Eigen::Vector3d> silhouette_points;               // local, on the surface
};

// A target placed at one instant: world foot point.
struct PlacedTarget {
  const CompiledTarget* target = nullptr;
  Eigen::Vector3d foot = Eigen::Vector3d::Zero();
};

// A placed target prepared for many rays from one camera centre: the centre in its local frame.
struct PreparedTarget {
  const CompiledTarget* target = nullptr;
  Eigen::Matrix3d R_local_world = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_local = Eigen::Vector3d::Zero();
};

class World {
 public:
  explicit World(const Scene& scene);

  const Scene& scene() const { return scene_; }
  const std::vector<CompiledTarget>& targets() const { return targets_; }
  std::vector<PlacedTarget> place(bool moving, double t_s) const;

  // Nearest hit of the ground, walls and the given placed targets along the unit ray d from o;
  // `hit` is only replaced by a nearer one.
  void trace_background(const Eigen::Vector3d& o, const Eigen::Vector3d& d, Hit& hit) const;
  static void trace_targets(const std::vector<PlacedTarget>& placed, const Eigen::Vector3d& o,
                            const Eigen::Vector3d& d, Hit& hit);
  // The same for rays from one centre o (prepare once, trace many rays).
  static std::vector<PreparedTarget> prepare(const std::vector<PlacedTarget>& placed,
                                             const Eigen::Vector3d& o);
  static void trace_targets(const std::vector<PreparedTarget>& prepared, const Eigen::Vector3d& d,
                            Hit& hit);
  static void trace_target(const PreparedTarget& prepared, const Eigen::Vector3d& d, Hit& hit);

  // Surface look at a hit; pixel_angle_rad sets the texture footprint.
  SurfaceSample shade(const Hit& hit, const Eigen::Vector3d& d, double pixel_angle_rad) const;

  // Visible-light shading of a normal (sun and sky), a factor in [0, 1].
  static float lighting(const Eigen::Vector3d& normal);

 private:
  Scene scene_;
  std::vector<TextureSampler> samplers_;
  std::vector<CompiledTarget> targets_;
  int road_texture_ = 0, verge_texture_ = 0, marking_texture_ = -1;
};

// In-band (8-14 um) radiance transfer of the infrared cameras: temperature -> signal counts
// (before fixed-pattern noise), by a tabulated Planck integral.
class InfraredTransfer {
 public:
  explicit InfraredTransfer(const InfraredBand& band);
  float counts(double temperature_c) const;

 private:
  std::vector<float> table_;  // counts per 0.05 K from kMinC
  static constexpr double kMinC = -80.0, kStepK = 0.05;
};

// Visible exposure: reflectance -> digital numbers, and the noise sigma of each DN.
struct VisibleExposure {
  explicit VisibleExposure(const VisibleBand& band);
  double white_dn = 0.0;  // DN of a white surface in full light
  double dn_per_e = 0.0;  // DN per electron after gain
  double gain = 1.0;      // analog gain applied
  double read_dn = 0.0;   // read noise, DN
  double sigma_dn(double dn) const;
};

}  // namespace thermovis::sim::detail
