#include "world.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace thermovis::sim::detail {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kEps = 1e-9;

// --- procedural noise -------------------------------------------------------------------------

std::uint32_t hash_u32(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

// A pseudo-random value in [-1, 1] per integer lattice point.
float lattice(std::int64_t ix, std::int64_t iy, std::uint32_t seed) {
  const std::uint32_t h = hash_u32(static_cast<std::uint32_t>(ix) * 0x9E3779B1U ^
                                   hash_u32(static_cast<std::uint32_t>(iy) + seed));
  return static_cast<float>(h) * (2.0f / 4294967295.0f) - 1.0f;
}

// Smoothly interpolated lattice values (value noise), in [-1, 1].
float value_noise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx);
  const auto iy = static_cast<std::int64_t>(fy);
  const double tx = x - fx, ty = y - fy;
  const double wx = tx * tx * (3.0 - 2.0 * tx), wy = ty * ty * (3.0 - 2.0 * ty);
  const double a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const double c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  return static_cast<float>((a + (b - a) * wx) + ((c + (d - c) * wx) - (a + (b - a) * wx)) * wy);
}

// Weight of detail of size cell_m seen with a pixel footprint of footprint_m: 1 when resolved,
// fading to 0 under two footprints (so far or grazing surfaces do not alias).
double detail_weight(double cell_m, double footprint_m) {
  return std::clamp(cell_m / (2.0 * footprint_m) - 0.5, 0.0, 1.0);
}

double smoothstep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

std::uint32_t name_seed(const std::string& name) {
  std::uint32_t h = 2166136261U;  // FNV-1a
  for (char ch : name) h = (h ^ static_cast<unsigned char>(ch)) * 16777619U;
  return h;
}

// --- ray / primitive intersection in a target's local frame -----------------------------------

struct LocalHit {
  double t = std::numeric_limits<double>::infinity();
  Eigen::Vector3d point, normal;
  double u = 0.0, v = 0.0;
  int texture = -1;
};

// Surface coordinates around a vertical axis through (cx, cz): arc length from the side facing
// -z (towards a rig straight ahead), so the texture seam is at the back.
double around_axis(const Eigen::Vector3d& p, const Eigen::Vector3d& c, double radius) {
  return std::atan2(p.x() - c.x(), -(p.z() - c.z())) * radius;
}

// True when the ray (o, d) surely misses the primitive's bounding sphere, or meets it only
// behind the origin: no hit is possible. d need not be exactly unit.
bool misses_bound(const Primitive& prim, const Eigen::Vector3d& rel, const Eigen::Vector3d& d) {
  const double b = rel.dot(d);
  const double rr = rel.squaredNorm();
  if (rr <= prim.bound_radius2) return false;  // the origin is inside the bound
  if (b >= 0.0) return true;                   // outside and heading away
  const double dd = d.squaredNorm();
  return rr * dd - b * b > prim.bound_radius2 * dd;  // the line's distance from the centre
}

void intersect(const Primitive& prim, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
               LocalHit& best) {
  const Eigen::Vector3d rel = o - prim.centre;
  if (prim.kind != Primitive::Kind::sphere && misses_bound(prim, rel, d)) return;
  switch (prim.kind) {
    case Primitive::Kind::box: {
      double t_near = -std::numeric_limits<double>::infinity();
      double t_far = std::numeric_limits<double>::infinity();
      int axis = -1;
      double sign = 0.0;
      for (int i = 0; i < 3; ++i) {
        if (std::abs(d[i]) < kEps) {
          if (std::abs(rel[i]) > prim.half[i]) return;
          continue;
        }
        double t0 = (-prim.half[i] - rel[i]) / d[i];
        double t1 = (prim.half[i] - rel[i]) / d[i];
        double s = -1.0;
        if (t0 > t1) {
          std::swap(t0, t1);
          s = 1.0;
        }
        if (t0 > t_near) {
          t_near = t0;
          axis = i;
          sign = s;
        }
        t_far = std::min(t_far, t1);
      }
      if (axis < 0 || t_near > t_far || t_near <= kEps || t_near >= best.t) return;
      best.t = t_near;
      best.point = o + t_near * d;
      best.normal = Eigen::Vector3d::Zero();
      best.normal[axis] = sign;
      // Face coordinates: the two other axes, "up" (-y) as v on vertical faces.
      if (axis == 0) {
        best.u = best.point.z();
        best.v = -best.point.y();
      } else if (axis == 2) {
        best.u = best.point.x();
        best.v = -best.point.y();
      } else {
        best.u = best.point.x();
        best.v = best.point.z();
      }
      best.texture = prim.texture;
      return;
    }
    case Primitive::Kind::cylinder: {
      const double rx = prim.half.x(), rz = prim.half.z(), hy = prim.half.y();
      const double kx = 1.0 / (rx * rx), kz = 1.0 / (rz * rz);
      const double a = d.x() * d.x() * kx + d.z() * d.z() * kz;
      const double b = 2.0 * (rel.x() * d.x() * kx + rel.z() * d.z() * kz);
      const double c = rel.x() * rel.x() * kx + rel.z() * rel.z() * kz - 1.0;
      if (a > kEps) {
        const double disc = b * b - 4.0 * a * c;
        if (disc >= 0.0) {
          const double t = (-b - std::sqrt(disc)) / (2.0 * a);
          const double y = rel.y() + t * d.y();
          if (t > kEps && t < best.t && std::abs(y) <= hy) {
            best.t = t;
            best.point = o + t * d;
            const Eigen::Vector3d r = best.point - prim.centre;
            best.normal = Eigen::Vector3d(r.x() * kx, 0.0, r.z() * kz).normalized();
            best.u = around_axis(best.point, prim.centre, 0.5 * (rx + rz));
            best.v = -best.point.y();
            best.texture = prim.texture;
          }
        }
      }
      if (std::abs(d.y()) > kEps) {  // the caps
        const double inv_dy = 1.0 / d.y();
        for (double cap : {-hy, hy}) {
          const double t = (cap - rel.y()) * inv_dy;
          if (t <= kEps || t >= best.t) continue;
          const double x = rel.x() + t * d.x(), z = rel.z() + t * d.z();
          if (x * x * kx + z * z * kz > 1.0) continue;
          best.t = t;
          best.point = o + t * d;
          best.normal = Eigen::Vector3d(0.0, cap > 0.0 ? 1.0 : -1.0, 0.0);
          best.u = best.point.x();
          best.v = best.point.z();
          best.texture = prim.texture;
        }
      }
      return;
    }
    case Primitive::Kind::sphere: {
      // d need not be exactly unit (interpolated rays): the full quadratic, so that the
      // silhouette's edge does not move with the ray's length.
      const double r = prim.half.x();
      const double a = d.squaredNorm();
      const double b = rel.dot(d);
      const double c = rel.squaredNorm() - r * r;
      const double disc = b * b - a * c;
      if (disc < 0.0) return;
      const double t = (-b - std::sqrt(disc)) / a;
      if (t <= kEps || t >= best.t) return;
      best.t = t;
      best.point = o + t * d;
      best.normal = (best.point - prim.centre) / r;
      best.u = around_axis(best.point, prim.centre, r);
      best.v = std::asin(std::clamp(-best.normal.y(), -1.0, 1.0)) * r;
      best.texture = prim.texture;
      return;
    }
  }
}

// --- target shapes ------------------------------------------------------------------------------

// A bounding radius squared with a relative margin far above rounding errors.
double padded_radius2(double radius) {
  const double padded = radius * (1.0 + 1e-6) + 1e-9;
  return padded * padded;
}

Primitive box(Eigen::Vector3d centre, Eigen::Vector3d half, int texture) {
  return {Primitive::Kind::box, centre, half, texture, padded_radius2(half.norm())};
}
Primitive cylinder(double y_bottom, double y_top, double rx, double rz, int texture) {
  const double hy = 0.5 * std::abs(y_bottom - y_top);
  return {Primitive::Kind::cylinder, Eigen::Vector3d(0.0, 0.5 * (y_bottom + y_top), 0.0),
          Eigen::Vector3d(rx, hy, rz), texture, padded_radius2(std::hypot(std::max(rx, rz), hy))};
}
Primitive sphere(Eigen::Vector3d centre, double radius, int texture) {
  return {Primitive::Kind::sphere, centre, Eigen::Vector3d(radius, radius, radius), texture,
          padded_radius2(radius)};
}

CompiledTarget compile_target(const Scene& scene, const Target& raw, std::uint16_t id) {
  CompiledTarget ct;
  ct.spec = with_class_defaults(raw);
  ct.id = id;
  const Target& t = ct.spec;
  const double h = t.height_m, w = t.width_m, l = t.length_m;
  const int main = scene.texture_index(t.texture);
  const auto named = [&](const char* name) {
    const int i = scene.texture_index(name);
    if (i < 0) throw std::invalid_argument(std::string("missing texture '") + name + "'");
    return i;
  };
  switch (t.cls) {
    case TargetClass::person: {
      const int skin = named("skin");
      const double head_r = 0.07 * h;
      ct.parts = {cylinder(0.0, -0.4714 * h, 0.4 * w, 0.45 * l, named("trousers")),
                  cylinder(-0.4714 * h, -0.81 * h, 0.5 * w, 0.5 * l, main),
                  cylinder(-0.80 * h, -(h - 1.8 * head_r), 0.12 * w, 0.12 * w, skin),
                  sphere(Eigen::Vector3d(0.0, -(h - head_r), 0.0), head_r, skin)};
      break;
    }
    case TargetClass::car:
      ct.parts = {box(Eigen::Vector3d(0.0, -0.1 * h, 0.0),
                      Eigen::Vector3d(0.45 * w, 0.1 * h, 0.42 * l), named("tyre")),
                  box(Eigen::Vector3d(0.0, -0.4 * h, 0.0),
                      Eigen::Vector3d(0.5 * w, 0.2 * h, 0.5 * l), main),
                  box(Eigen::Vector3d(0.0, -0.8 * h, -0.05 * l),
                      Eigen::Vector3d(0.45 * w, 0.2 * h, 0.25 * l), named("glass"))};
      break;
    case TargetClass::pole:
      ct.parts = {cylinder(0.0, -h, 0.5 * w, 0.5 * w, main)};
      break;
    case TargetClass::marker:
      ct.parts = {sphere(Eigen::Vector3d(0.0, -0.5 * w, 0.0), 0.5 * w, main)};
      break;
  }
  const double heading = t.heading_deg * kPi / 180.0;
  ct.R_world_local = Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitY()).toRotationMatrix();
  ct.bound_lo = Eigen::Vector3d(-0.5 * w, -h, -0.5 * l);
  ct.bound_hi = Eigen::Vector3d(0.5 * w, 0.0, 0.5 * l);
  // Points on every part's surface, dense enough that their projected extent is the
  // silhouette's to a small fraction of a pixel for targets beyond about 2 m.
  for (const Primitive& p : ct.parts) {
    if (p.kind == Primitive::Kind::sphere) {
      const int n = 400;
      for (int i = 0; i < n; ++i) {  // Fibonacci sphere
        const double y = 1.0 - 2.0 * (i + 0.5) / n;
        const double r = std::sqrt(1.0 - y * y);
        const double phi = i * kPi * (3.0 - std::sqrt(5.0));
        ct.silhouette_points.push_back(
            p.centre + p.half.x() * Eigen::Vector3d(r * std::cos(phi), y, r * std::sin(phi)));
      }
    } else if (p.kind == Primitive::Kind::cylinder) {
      for (int i = 0; i < 72; ++i) {
        const double a = 2.0 * kPi * i / 72;
        for (int j = 0; j <= 4; ++j) {
          const double y = -p.half.y() + 2.0 * p.half.y() * j / 4.0;
          ct.silhouette_points.push_back(
              p.centre + Eigen::Vector3d(p.half.x() * std::cos(a), y, p.half.z() * std::sin(a)));
        }
      }
    } else {
      for (int i = 0; i <= 8; ++i) {
        for (int j = 0; j <= 8; ++j) {
          for (int k = 0; k <= 8; ++k) {
            if (i % 8 != 0 && j % 8 != 0 && k % 8 != 0) continue;  // surface only
            const Eigen::Vector3d f(i / 4.0 - 1.0, j / 4.0 - 1.0, k / 4.0 - 1.0);
            ct.silhouette_points.push_back(p.centre + p.half.cwiseProduct(f));
          }
        }
      }
    }
  }
  return ct;
}

}  // namespace

// --- textures
// -------------------------------------------------------------------------------------

TextureSampler::TextureSampler(const Texture& texture, double ambient_c)
    : texture_(texture),
      mean_temperature_c_(texture.temperature_c ? *texture.temperature_c
                                                : ambient_c + texture.temperature_offset_k),
      seed_(name_seed(texture.name)) {}

SurfaceSample TextureSampler::sample(double u, double v, double footprint_m) const {
  const Texture& tx = texture_;
  const double s = tx.scale_m;
  double p = 0.0;           // weight of colour2
  double brightness = 1.0;  // per-cell variation (bricks)
  const bool two_colour = tx.pattern != TexturePattern::uniform;
  switch (tx.pattern) {
    case TexturePattern::uniform:
      break;
    case TexturePattern::noise:
      p = 0.5 + 0.5 * detail_weight(4.0 * s, footprint_m) *
                    value_noise(u / (4.0 * s), v / (4.0 * s), seed_ + 10);
      break;
    case TexturePattern::stripes: {
      const double raw = (u / s - std::floor(u / s)) < 0.5 ? 0.0 : 1.0;
      p = 0.5 + (raw - 0.5) * detail_weight(0.5 * s, footprint_m);
      break;
    }
    case TexturePattern::checker: {
      const auto parity = static_cast<std::int64_t>(std::floor(u / s) + std::floor(v / s));
      const double raw = (parity & 1) != 0 ? 1.0 : 0.0;
      p = 0.5 + (raw - 0.5) * detail_weight(s, footprint_m);
      break;
    }
    case TexturePattern::brick: {
      const double bh = s / 3.0;
      const double mortar = 0.04 * s;
      const double row = std::floor(v / bh);
      const double uu = u / s + ((static_cast<std::int64_t>(row) & 1) != 0 ? 0.5 : 0.0);
      const double fu = (uu - std::floor(uu)) * s, fv = (v / bh - row) * bh;
      const double raw = (fu < mortar || fv < mortar) ? 1.0 : 0.0;
      const double mean = mortar / s + mortar / bh;
      p = mean + (raw - mean) * detail_weight(2.0 * mortar, footprint_m);
      brightness = 1.0 + 0.15 * detail_weight(bh, footprint_m) *
                             lattice(static_cast<std::int64_t>(std::floor(uu)),
                                     static_cast<std::int64_t>(row), seed_ + 20);
      break;
    }
    case TexturePattern::foliage: {
      const double f = value_noise(u / s, v / s, seed_ + 30) +
                       0.5 * value_noise(2.0 * u / s, 2.0 * v / s, seed_ + 31);
      p = 0.5 + (smoothstep(-0.15, 0.15, f) - 0.5) * detail_weight(0.5 * s, footprint_m);
      break;
    }
  }
  // Fine grain: three octaves of value noise under the pattern.
  double grain = 0.0;
  if (tx.contrast > 0.0 || tx.temperature_contrast_k > 0.0) {
    const double cell = tx.pattern == TexturePattern::noise ? s : 0.25 * s;
    const double amps[3] = {0.5, 0.3, 0.2};
    for (int k = 0; k < 3; ++k) {
      const double c = cell / static_cast<double>(1 << k);
      const double wgt = detail_weight(c, footprint_m);
      if (wgt <= 0.0) break;
      grain += amps[k] * wgt * value_noise(u / c, v / c, seed_ + static_cast<std::uint32_t>(k));
    }
  }
  SurfaceSample out;
  const Eigen::Vector3d colour =
      ((1.0 - p) * tx.colour + p * tx.colour2) * brightness * (1.0 + tx.contrast * grain);
  out.reflectance_bgr = colour.cwiseMax(0.0).cwiseMin(1.0).cast<float>();
  const double pattern_k = two_colour ? 0.6 * (1.0 - 2.0 * p) : 0.0;
  out.temperature_c = static_cast<float>(mean_temperature_c_ +
                                         tx.temperature_contrast_k * (pattern_k + 0.4 * grain));
  return out;
}

// --- the world
// ------------------------------------------------------------------------------------

World::World(const Scene& scene) : scene_(scene) {
  for (const Texture& t : scene_.textures) samplers_.emplace_back(t, scene_.infrared.ambient_c);
  road_texture_ = scene_.texture_index(scene_.ground.road_texture);
  verge_texture_ = scene_.texture_index(scene_.ground.verge_texture);
  marking_texture_ = scene_.ground.centre_line ? scene_.texture_index("road_marking") : -1;
  if (road_texture_ < 0 || verge_texture_ < 0)
    throw std::invalid_argument("ground: missing texture");
  for (std::size_t i = 0; i < scene_.targets.size(); ++i) {
    targets_.push_back(
        compile_target(scene_, scene_.targets[i], static_cast<std::uint16_t>(kFirstTargetId + i)));
  }
}

std::vector<PlacedTarget> World::place(bool moving, double t_s) const {
  std::vector<PlacedTarget> out;
  for (const CompiledTarget& t : targets_) {
    if (t.spec.moving() != moving) continue;
    out.push_back({&t, foot_position(scene_, t.spec, t_s)});
  }
  return out;
}

void World::trace_background(const Eigen::Vector3d& o, const Eigen::Vector3d& d, Hit& hit) const {
  const double ground_y = scene_.camera_height_m;
  if (d.y() > kEps) {
    const double t = (ground_y - o.y()) / d.y();
    if (t > kEps && t < hit.t && t < 1e5) {
      const double x = o.x() + t * d.x(), z = o.z() + t * d.z();
      const double across = std::abs(x - scene_.ground.road_centre_x_m);
      hit.t = t;
      hit.id = kGroundId;
      hit.u = x;
      hit.v = z;
      hit.normal = Eigen::Vector3d(0.0, -1.0, 0.0);
      hit.texture = across < scene_.ground.road_half_width_m ? road_texture_ : verge_texture_;
      // Dashed centre line: 3 m dashes, 3 m gaps, 0.12 m wide.
      if (marking_texture_ >= 0 && across < 0.06 && (z / 6.0 - std::floor(z / 6.0)) < 0.5)
        hit.texture = marking_texture_;
    }
  }
  for (std::size_t i = 0; i < scene_.walls.size(); ++i) {
    const Wall& w = scene_.walls[i];
    const Eigen::Vector2d along = (w.to - w.from).normalized();
    const double length = (w.to - w.from).norm();
    const Eigen::Vector2d n(-along.y(), along.x());  // (x, z) normal
    const double denom = n.x() * d.x() + n.y() * d.z();
    if (std::abs(denom) < kEps) continue;
    const double t = (n.x() * (w.from.x() - o.x()) + n.y() * (w.from.y() - o.z())) / denom;
    if (t <= kEps || t >= hit.t) continue;
    const Eigen::Vector3d p = o + t * d;
    const double s = (p.x() - w.from.x()) * along.x() + (p.z() - w.from.y()) * along.y();
    const double up = ground_y - p.y();
    if (s < 0.0 || s > length || up < 0.0 || up > w.height_m) continue;
    hit.t = t;
    hit.id = static_cast<std::uint16_t>(kFirstWallId + i);
    hit.u = s;
    hit.v = up;
    hit.normal = Eigen::Vector3d(n.x(), 0.0, n.y()) * (denom > 0.0 ? -1.0 : 1.0);
    hit.texture = scene_.texture_index(w.texture);
  }
}

namespace {

// One target along a ray given in its local frame (origin ol, direction dl).
void trace_local(const CompiledTarget& t, const Eigen::Matrix3d& R_world_local,
                 const Eigen::Vector3d& ol, const Eigen::Vector3d& dl, Hit& hit) {
  // Quick rejection by the local bounding box (slabs).
  double t0 = 0.0, t1 = hit.t;
  for (int i = 0; i < 3; ++i) {
    if (std::abs(dl[i]) < kEps) {
      if (ol[i] < t.bound_lo[i] || ol[i] > t.bound_hi[i]) return;
      continue;
    }
    const double inv = 1.0 / dl[i];
    double a = (t.bound_lo[i] - ol[i]) * inv, b = (t.bound_hi[i] - ol[i]) * inv;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    if (t0 > t1) return;
  }
  LocalHit best;
  best.t = hit.t;
  for (const Primitive& p : t.parts) intersect(p, ol, dl, best);
  if (best.texture < 0) return;
  hit.t = best.t;
  hit.id = t.id;
  hit.u = best.u;
  hit.v = best.v;
  hit.texture = best.texture;
  hit.normal = R_world_local * best.normal;
}

}  // namespace

void World::trace_targets(const std::vector<PlacedTarget>& placed, const Eigen::Vector3d& o,
                          const Eigen::Vector3d& d, Hit& hit) {
  for (const PlacedTarget& pt : placed) {
    const CompiledTarget& t = *pt.target;
    trace_local(t, t.R_world_local, t.R_world_local.transpose() * (o - pt.foot),
                t.R_world_local.transpose() * d, hit);
  }
}

std::vector<PreparedTarget> World::prepare(const std::vector<PlacedTarget>& placed,
                                           const Eigen::Vector3d& o) {
  std::vector<PreparedTarget> out;
  out.reserve(placed.size());
  for (const PlacedTarget& pt : placed) {
    const Eigen::Matrix3d R_local_world = pt.target->R_world_local.transpose();
    out.push_back({pt.target, R_local_world, R_local_world * (o - pt.foot)});
  }
  return out;
}

void World::trace_targets(const std::vector<PreparedTarget>& prepared, const Eigen::Vector3d& d,
                          Hit& hit) {
  for (const PreparedTarget& pt : prepared) trace_target(pt, d, hit);
}

void World::trace_target(const PreparedTarget& pt, const Eigen::Vector3d& d, Hit& hit) {
  trace_local(*pt.target, pt.target->R_world_local, pt.origin_local, pt.R_local_world * d, hit);
}

SurfaceSample World::shade(const Hit& hit, const Eigen::Vector3d& d, double pixel_angle_rad) const {
  const double cosine = std::max(0.05, std::abs(hit.normal.dot(d)));
  const double footprint = hit.t * pixel_angle_rad / cosine;
  return samplers_[static_cast<std::size_t>(hit.texture)].sample(hit.u, hit.v, footprint);
}

float World::lighting(const Eigen::Vector3d& normal) {
  // Sun high, behind and to the left of the rig; the rest is sky light.
  static const Eigen::Vector3d sun = Eigen::Vector3d(-0.35, -0.8, -0.45).normalized();
  return static_cast<float>(0.55 + 0.45 * std::max(0.0, normal.dot(sun)));
}

// --- radiometry
// -----------------------------------------------------------------------------------

namespace {

// Black-body radiance integrated over 8-14 um, W m^-2 sr^-1 (Simpson's rule over wavelength).
double band_radiance(double temperature_k) {
  constexpr double c1 = 1.191042e8;  // 2 h c^2, W um^4 m^-2 sr^-1
  constexpr double c2 = 14387.77;    // h c / k, um K
  constexpr int n = 120;
  const double a = 8.0, b = 14.0, step = (b - a) / n;
  double sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double lambda = a + i * step;
    const double value = c1 / (std::pow(lambda, 5) * (std::exp(c2 / (lambda * temperature_k)) - 1));
    sum += value * (i == 0 || i == n ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0));
  }
  return sum * step / 3.0;
}

}  // namespace

InfraredTransfer::InfraredTransfer(const InfraredBand& band) {
  const double t20 = 273.15 + 20.0;
  const double l20 = band_radiance(t20);
  const double slope = (band_radiance(t20 + 0.5) - band_radiance(t20 - 0.5));  // per K
  const int n = static_cast<int>((230.0 - kMinC) / kStepK) + 1;
  table_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const double t = 273.15 + kMinC + i * kStepK;
    table_[static_cast<std::size_t>(i)] = static_cast<float>(
        band.counts_at_20c + band.counts_per_k * (band_radiance(t) - l20) / slope);
  }
}

float InfraredTransfer::counts(double temperature_c) const {
  const double x =
      std::clamp((temperature_c - kMinC) / kStepK, 0.0, static_cast<double>(table_.size() - 2));
  const auto i = static_cast<std::size_t>(x);
  const double f = x - static_cast<double>(i);
  return static_cast<float>(table_[i] + f * (table_[i + 1] - table_[i]));
}

VisibleExposure::VisibleExposure(const VisibleBand& band) {
  // Auto exposure brings white to 80 % of the full well when there is light enough; below that
  // the gain rises (up to max_gain), and with it the noise.
  const double target_e = 0.8 * band.full_well_e;
  const double white_e = std::min(band.illuminance_lux * band.electrons_per_lux, target_e);
  gain = white_e > 0.0 ? std::clamp(target_e / white_e, 1.0, band.max_gain) : band.max_gain;
  dn_per_e = gain * 255.0 / band.full_well_e;
  white_dn = white_e * dn_per_e;
  read_dn = band.read_noise_e * dn_per_e;
}

double VisibleExposure::sigma_dn(double dn) const {
  return std::sqrt(std::max(0.0, dn) * dn_per_e + read_dn * read_dn);
}

}  // namespace thermovis::sim::detail
