#include "thermovis/sim/simulated_rig.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "camera_layers.hpp"
#include "renderer.hpp"
#include "sensor_noise.hpp"
#include "static_cache.hpp"
#include "thermovis/util/enum_names.hpp"
#include "world.hpp"

namespace thermovis::sim {
namespace {

constexpr util::EnumName<Slot> kSlotNames[] = {{Slot::visible_left, "visible_left"},
                                               {Slot::visible_right, "visible_right"},
                                               {Slot::infrared_left, "infrared_left"},
                                               {Slot::infrared_right, "infrared_right"}};

using detail::CameraLayers;
using detail::Hit;
using detail::PlacedTarget;

// The cameras of the four slots, in Slot order; throws std::invalid_argument when the rig
// lacks one or its model, or an infrared bit depth is out of range.
std::array<const camera::RigCamera*, kSlotCount> slot_cameras(const camera::Rig& rig) {
  const std::array<std::string, kSlotCount> names = {rig.visible.left, rig.visible.right,
                                                     rig.infrared.left, rig.infrared.right};
  for (const std::string& name : names) {
    if (!rig.has_camera(name))
      throw std::invalid_argument("simulated rig: the rig has no camera '" + name + "'");
    if (!rig.camera(name).model)
      throw std::invalid_argument("simulated rig: camera '" + name + "' has no model");
  }
  for (int i = 2; i < 4; ++i) {
    const int bits = rig.camera(names[static_cast<std::size_t>(i)]).bit_depth;
    if (bits < 1 || bits > 16)
      throw std::invalid_argument("simulated rig: infrared bit_depth must be 1..16");
  }
  std::array<const camera::RigCamera*, kSlotCount> out{};
  for (int i = 0; i < kSlotCount; ++i)
    out[static_cast<std::size_t>(i)] = &rig.camera(names[static_cast<std::size_t>(i)]);
  return out;
}

}  // namespace

const char* to_string(Slot slot) { return util::name_of(kSlotNames, slot, "unknown"); }

struct SimulatedRig::Impl {
  camera::Rig rig;
  Scene scene;
  std::array<const camera::RigCamera*, kSlotCount> slot_camera;  // into `rig`
  detail::Renderer renderer;
  detail::SensorNoise noise;
  std::array<CameraLayers, kSlotCount> cams;
  Eigen::Isometry3d T_visible_left_world = Eigen::Isometry3d::Identity();
  StaticSetup static_setup;
  std::shared_ptr<void> static_mapping;  // the cache file the static layers point into

  Impl(camera::Rig r, Scene s, std::uint64_t seed, RenderOptions options)
      : rig(std::move(r)),
        scene(std::move(s)),
        slot_camera(slot_cameras(rig)),
        renderer(scene),
        noise(scene, seed, options) {}

  double time_s(std::int64_t frame_index) const {
    return static_cast<double>(frame_index) / scene.frame_rate_hz;
  }

  // Traces the static scene of every camera and draws its noise (the set-up the cache keeps).
  void build_static(std::size_t plane_size) {
    noise.draw_plane(plane_size);
    for (int i = 0; i < kSlotCount; ++i) {
      CameraLayers& c = cams[static_cast<std::size_t>(i)];
      renderer.trace_static_scene(c);
      if (!c.visible) noise.draw_fixed_pattern(static_cast<Slot>(i), c);
      renderer.finish_static_scene(c);
      if (c.visible) noise.visible_sigma(c.static_clean, c.static_sigma);
    }
  }

  // Renders camera slot `i` at frame `frame_index`, the moving targets placed at `moving`.
  void render_camera(int i, std::int64_t frame_index, const std::vector<PlacedTarget>& moving,
                     cv::Mat& img) const {
    const CameraLayers& c = cams[static_cast<std::size_t>(i)];
    const std::uint64_t key = noise.image_key(frame_index, static_cast<Slot>(i));
    const cv::Rect whole(cv::Point(0, 0), c.size);
    noise.add(c, c.static_clean, c.visible ? &c.static_sigma : nullptr, whole, key, img);
    const std::vector<cv::Rect> rects = renderer.regions(c, moving);
    const int rb = renderer.blur_radius(c);
    std::vector<PlacedTarget> local;
    std::vector<cv::Rect> local_rects;
    for (const cv::Rect& r : rects) {
      if (r.area() == 0) continue;
      // Only the moving targets whose own region reaches this one can cover its pixels.
      const cv::Rect reach(r.x - rb, r.y - rb, r.width + 2 * rb, r.height + 2 * rb);
      local.clear();
      local_rects.clear();
      for (std::size_t k = 0; k < moving.size(); ++k) {
        if ((rects[k] & reach).area() == 0) continue;
        local.push_back(moving[k]);
        local_rects.push_back(rects[k]);
      }
      cv::Mat clean;
      renderer.render_region(c, r, local, local_rects, clean);
      noise.add(c, clean, nullptr, r, key, img);
    }
  }
};

SimulatedRig::SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options)
    : SimulatedRig(std::move(rig), std::move(scene), seed, options, StaticCache{}) {}

SimulatedRig::SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options,
                           const StaticCache& cache) {
  validate(scene);
  impl_ = std::make_unique<Impl>(std::move(rig), std::move(scene), seed, options);
  Impl& m = *impl_;
  m.T_visible_left_world = m.rig.camera(m.rig.visible.left).T_ref_cam.inverse();
  // The noise plane: long enough for the longest row at any offset.
  std::size_t longest = 0;
  for (int i = 0; i < kSlotCount; ++i) {
    const camera::RigCamera& cam = *m.slot_camera[static_cast<std::size_t>(i)];
    m.cams[static_cast<std::size_t>(i)] = detail::camera_geometry(static_cast<Slot>(i), cam);
    const cv::Size size = cam.model->image_size();
    longest = std::max(longest, static_cast<std::size_t>(size.width) * (i < 2 ? 3 : 1));
  }
  const std::size_t plane_size = detail::SensorNoise::plane_size(longest);
  // The file also holds what the seed and the fixed-pattern option decide.
  const std::string key = cache.key + " | seed " + std::to_string(seed) + ", fixed pattern " +
                          (options.fixed_pattern ? "on" : "off");
  if (!cache.file.empty()) {
    m.static_setup.note = detail::read_static_cache(cache.file, key, m.cams, plane_size,
                                                    m.noise.plane(), m.static_mapping);
    m.static_setup.loaded = m.static_setup.note.empty();
  }
  if (m.static_setup.loaded) return;
  // Layers a rejected file got as far as pointing into its mapping: released before it goes
  // (create() would keep a view of the same size and type).
  for (CameraLayers& c : m.cams) {
    for (cv::Mat* layer : detail::cached_layers(c)) layer->release();
  }
  m.static_mapping.reset();
  m.build_static(plane_size);
  if (!cache.file.empty()) {
    const std::string written =
        detail::write_static_cache(cache.file, key, m.cams, m.noise.plane());
    if (!written.empty()) m.static_setup.note += "; " + written;
  }
}

SimulatedRig::~SimulatedRig() = default;
SimulatedRig::SimulatedRig(SimulatedRig&&) noexcept = default;
SimulatedRig& SimulatedRig::operator=(SimulatedRig&&) noexcept = default;

const camera::Rig& SimulatedRig::rig() const { return impl_->rig; }
const StaticSetup& SimulatedRig::static_setup() const { return impl_->static_setup; }
const Scene& SimulatedRig::scene() const { return impl_->scene; }
const camera::RigCamera& SimulatedRig::camera(Slot slot) const {
  return *impl_->cams[static_cast<int>(slot)].camera;
}

FrameSet SimulatedRig::allocate() const {
  FrameSet out;
  for (int i = 0; i < kSlotCount; ++i) {
    const CameraLayers& c = impl_->cams[static_cast<std::size_t>(i)];
    out.images[static_cast<std::size_t>(i)].create(c.size, c.image_type());
  }
  return out;
}

void SimulatedRig::render(std::int64_t frame_index, FrameSet& out) const {
  const Impl& m = *impl_;
  for (int i = 0; i < kSlotCount; ++i) {
    const CameraLayers& c = m.cams[static_cast<std::size_t>(i)];
    const cv::Mat& img = out.images[static_cast<std::size_t>(i)];
    if (img.size() != c.size || img.type() != c.image_type() || !img.isContinuous()) {
      throw std::invalid_argument(
          std::string("simulated rig: buffer ") + to_string(static_cast<Slot>(i)) +
          " must be a continuous " + std::to_string(c.size.width) + "x" +
          std::to_string(c.size.height) + (c.visible ? " CV_8UC3" : " CV_16UC1") + " image");
    }
  }
  const std::vector<PlacedTarget> moving = m.renderer.world().place(true, m.time_s(frame_index));
  for (int i = 0; i < kSlotCount; ++i)
    m.render_camera(i, frame_index, moving, out.images[static_cast<std::size_t>(i)]);
}

std::int64_t SimulatedRig::dynamic_pixel_count(std::int64_t frame_index) const {
  const Impl& m = *impl_;
  const std::vector<PlacedTarget> moving = m.renderer.world().place(true, m.time_s(frame_index));
  std::int64_t total = 0;
  for (const CameraLayers& c : m.cams) {
    for (const cv::Rect& r : m.renderer.regions(c, moving)) total += r.area();
  }
  return total;
}

std::vector<TargetTruth> SimulatedRig::truth(std::int64_t frame_index) const {
  const Impl& m = *impl_;
  const double t_s = m.time_s(frame_index);
  std::vector<TargetTruth> out;
  for (const detail::CompiledTarget& t : m.renderer.world().targets()) {
    TargetTruth truth;
    truth.id = t.spec.id;
    truth.cls = t.spec.cls;
    const Eigen::Vector3d foot = foot_position(m.scene, t.spec, t_s);
    truth.position_m = m.T_visible_left_world * centre_position(m.scene, t.spec, t_s);
    truth.distance_m = truth.position_m.norm();
    truth.surface_points_m.reserve(t.silhouette_points.size());
    for (const Eigen::Vector3d& p : t.silhouette_points) {
      truth.surface_points_m.push_back(m.T_visible_left_world * (foot + t.R_world_local * p));
    }
    for (int i = 0; i < kSlotCount; ++i) {
      const CameraLayers& c = m.cams[static_cast<std::size_t>(i)];
      const auto extent = m.renderer.projected_extent(c, t.silhouette_points, t, foot);
      if (!extent) continue;
      TruthBox box = *extent;
      const double w = c.size.width - 0.5, h = c.size.height - 0.5;
      box.x_min = std::max(box.x_min, -0.5);
      box.y_min = std::max(box.y_min, -0.5);
      box.x_max = std::min(box.x_max, w);
      box.y_max = std::min(box.y_max, h);
      if (box.x_min < box.x_max && box.y_min < box.y_max)
        truth.boxes[static_cast<std::size_t>(i)] = box;
    }
    out.push_back(std::move(truth));
  }
  return out;
}

RayTruth SimulatedRig::trace(const Eigen::Vector3d& origin_m, const Eigen::Vector3d& direction,
                             std::int64_t frame_index) const {
  const Impl& m = *impl_;
  const detail::World& world = m.renderer.world();
  RayTruth out;
  const double norm = direction.norm();
  if (!(norm > 0.0) || !origin_m.allFinite() || !direction.allFinite()) return out;
  const Eigen::Vector3d d = direction / norm;
  Hit hit;
  world.trace_background(origin_m, d, hit);
  detail::World::trace_targets(m.renderer.static_targets(), origin_m, d, hit);
  detail::World::trace_targets(world.place(true, m.time_s(frame_index)), origin_m, d, hit);
  if (hit.id == detail::kSkyId || !std::isfinite(hit.t)) return out;
  out.hit = true;
  out.distance_m = hit.t;
  if (hit.id >= detail::kFirstTargetId && hit.id != detail::kNoRayId) {
    const std::size_t i = hit.id - detail::kFirstTargetId;
    if (i < world.targets().size()) out.target_id = world.targets()[i].spec.id;
  }
  return out;
}

}  // namespace thermovis::sim
