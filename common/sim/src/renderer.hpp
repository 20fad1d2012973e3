#pragma once
// Internal: the simulated rig's renderer: each camera pixel's ray traced through the compiled
// scene (world.hpp) and shaded in its band, anti-aliased at edges, then turned into the
// camera's noise-free raw values (visible optical blur and 8-bit DN; infrared counts with the
// camera's fixed pattern). Sensor noise is sensor_noise.hpp's. World frame and units as in
// scene.hpp; pixel coordinates x = column, y = row, centres at integers.
#include <Eigen/Core>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

#include "camera_layers.hpp"
#include "thermovis/sim/scene.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "world.hpp"

namespace thermovis::sim::detail {

class Renderer {
 public:
  // `scene` must be valid (validate()).
  explicit Renderer(const Scene& scene);

  const World& world() const { return *world_; }
  // The targets that do not move, placed once.
  const std::vector<PlacedTarget>& static_targets() const { return static_targets_; }

  // Camera c's pixel rays and the static scene along them: rays, depth, surface id and linear
  // values of `c` (whose geometry is set), supersampled at edges.
  void trace_static_scene(CameraLayers& c) const;
  // The noise-free raw image of the static scene (static_clean of `c`) from its linear values,
  // blurred (visible) or through the fixed pattern (infrared: draw it first).
  void finish_static_scene(CameraLayers& c) const;

  // One image rectangle per moving target that may cover it in camera c, with a margin (empty
  // where it is out of the image).
  std::vector<cv::Rect> regions(const CameraLayers& c,
                                const std::vector<PlacedTarget>& moving) const;
  // Re-renders `out_rect` of camera c with the moving targets (whose regions are
  // `moving_regions`): its noise-free raw values into `clean` (of out_rect's size).
  void render_region(const CameraLayers& c, cv::Rect out_rect,
                     const std::vector<PlacedTarget>& moving,
                     const std::vector<cv::Rect>& moving_regions, cv::Mat& clean) const;
  // Pixels the visible blur reaches from a pixel (0 for infrared).
  int blur_radius(const CameraLayers& c) const;

  // Extent in camera c's image of a target's local points placed at `foot`, or nothing when no
  // point is in the lens's field. Points beyond the field stretch the extent to the image border
  // on their side (the target reaches past it). Not clipped to the image.
  std::optional<TruthBox> projected_extent(const CameraLayers& c,
                                           const std::vector<Eigen::Vector3d>& points,
                                           const CompiledTarget& target,
                                           const Eigen::Vector3d& foot) const;

 private:
  // Linear value of a ray: visible DN per channel (B, G, R), or infrared signal counts in [0].
  using Linear = cv::Vec3f;

  bool is_moving_id(std::uint16_t id) const;
  Linear radiance(const CameraLayers& c, const Hit& hit, const Eigen::Vector3d& d) const;
  Linear trace_static(const CameraLayers& c, const Eigen::Vector3d& d, Hit& hit) const;
  Linear supersample_static(const CameraLayers& c, int x, int y) const;
  Eigen::Vector3d ray_at(const CameraLayers& c, double px, double py) const;
  Linear supersample_moving(const CameraLayers& c, int x, int y,
                            const std::vector<const PreparedTarget*>& moving,
                            const Linear& static_value) const;
  void finish(const CameraLayers& c, const cv::Mat& linear, cv::Rect rect, cv::Mat& clean,
              bool blur) const;
  cv::Rect target_region(const CameraLayers& c, const PlacedTarget& pt) const;

  static void set_linear(cv::Mat& m, int y, int x, const Linear& v);
  static Linear get_linear(const cv::Mat& m, int y, int x);
  static bool on_edge(const cv::Mat& ids, int y, int x, const cv::Mat& static_ids,
                      cv::Point origin);
  static void covering(const std::vector<PreparedTarget>& prepared,
                       const std::vector<cv::Rect>& regions, int x, int y,
                       std::vector<const PreparedTarget*>& out);
  static std::vector<Eigen::Vector3d> hull_of(const CompiledTarget& t);

  std::unique_ptr<World> world_;
  VisibleExposure exposure_;
  InfraredTransfer ir_transfer_;
  std::vector<PlacedTarget> static_targets_;
  std::vector<std::vector<Eigen::Vector3d>> hull_points_;  // per target, local frame
  float sky_counts_ = 0.0f;
};

}  // namespace thermovis::sim::detail
