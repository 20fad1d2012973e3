#pragma once
// The simulated dual-band rig: renders a Scene through the four cameras of a Rig (each pixel's
// ray from the camera's own model and pose), with ground truth for every target.
//
// Images (raw, as the cameras deliver them):
//  visible left/right:  CV_8UC3, BGR, 8 bits, the camera model's size (1920x1080 for the paper);
//  infrared left/right: CV_16UC1, raw counts with `bit_depth` bits used (14 for the paper).
//
// Cost: construction renders the static scene (ground, walls, sky and targets that do not
// move) once per camera, anti-aliased at edges, and draws one normal noise plane for the seed.
// render() then copies the static image through the noise step (each row of each image reads
// the noise plane from its own pseudo-random offset) and re-renders only the pixels the moving
// targets' boxes cover.
//
// Determinism: the images of frame k depend only on (rig, scene, seed, options, k): same inputs,
// same bytes, in any order of frames. The scene's textures do not depend on the seed; the noise
// (temporal and fixed-pattern) does.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "thermovis/camera/rig.hpp"
#include "thermovis/sim/scene.hpp"

namespace thermovis::sim {

// The four cameras, in this order everywhere (FrameSet, truth boxes).
enum class Slot { visible_left = 0, visible_right = 1, infrared_left = 2, infrared_right = 3 };
inline constexpr int kSlotCount = 4;
const char* to_string(Slot slot);  // "visible_left", ...

struct FrameSet {
  std::array<cv::Mat, kSlotCount> images;  // indexed by Slot
  cv::Mat& operator[](Slot slot) { return images[static_cast<int>(slot)]; }
  const cv::Mat& operator[](Slot slot) const { return images[static_cast<int>(slot)]; }
};

struct RenderOptions {
  bool temporal_noise = true;  // visible shot + read noise, infrared NETD noise
  bool fixed_pattern = true;   // infrared offset / gain non-uniformity
};

// A target's box in one raw image: the extent of its projected silhouette (occlusion ignored),
// pixel coordinates (x = column, y = row, centres at integers), clipped to the image.
struct TruthBox {
  double x_min = 0.0, y_min = 0.0, x_max = 0.0, y_max = 0.0;
};

struct TargetTruth {
  std::string id;
  TargetClass cls = TargetClass::person;
  // Centre of the target's bounding box in the left visible camera's frame, m.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  double distance_m = 0.0;                                // |position_m|
  std::array<std::optional<TruthBox>, kSlotCount> boxes;  // empty where it is not in the image
  // Points on the target's surface (left visible camera's frame, m), dense enough that their
  // projected extent is the silhouette's to a fraction of a pixel beyond about 2 m: `boxes` are
  // their extents in each raw image. A rectified image's box is theirs too (projected there);
  // a raw box carried onto another grid is wider, by the turn of the box's border.
  std::vector<Eigen::Vector3d> surface_points_m;
};

// A file that keeps what a SimulatedRig's construction computes (each pixel's ray and the static
// scene along it, the noise-free static images, the fixed-pattern and temporal noise tables:
// about 3 s of CPU for the paper's rig and scene) from one SimulatedRig to the next, so a
// restarted simulator is ready in a fraction of a second (the file is mapped, not read: its
// pages are the images). The file holds `key` and is used only by a rig given the same key: the
// caller makes the key change with anything the static scene depends on (the rig, the scene,
// the simulator's code); the rig adds the seed and the fixed-pattern option to it. About 200 MB
// for the paper's rig.
struct StaticCache {
  std::filesystem::path file;
  std::string key;
};

// How a SimulatedRig got its static scene.
struct StaticSetup {
  bool loaded = false;  // read from the cache file (else traced)
  std::string note;     // why the cache was not read or not written ("" when all went well)
};

// What one ray meets in the scene (ground truth for per-point checks of matching and ranging).
struct RayTruth {
  bool hit = false;         // false: the ray reaches the sky
  double distance_m = 0.0;  // along the unit ray from its origin, m (hit only)
  std::string target_id;    // the target hit; empty for the ground, walls and sky
};

class SimulatedRig {
 public:
  // The rig must have the cameras its `visible` and `infrared` pairs name. Throws
  // std::invalid_argument for an invalid scene (validate()) or rig.
  SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options = {});
  // The same, reading the traced static scene from `cache` when the file holds `cache.key` and
  // fits the rig; otherwise traces it and writes the file (to a temporary name, then renamed,
  // so a reader never sees half a file; never rewrite a file in place while a rig maps it). A
  // missing, foreign, truncated or garbled file, or one that cannot be written, is never an
  // error: the rig traces the scene and static_setup() says why. The images are the same bytes
  // either way.
  SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options,
               const StaticCache& cache);
  ~SimulatedRig();
  SimulatedRig(SimulatedRig&&) noexcept;
  SimulatedRig& operator=(SimulatedRig&&) noexcept;

  const camera::Rig& rig() const;
  const StaticSetup& static_setup() const;
  const Scene& scene() const;
  const camera::RigCamera& camera(Slot slot) const;

  // Buffers of the right sizes and types for render().
  FrameSet allocate() const;
  // Renders frame `frame_index` (time frame_index / frame_rate_hz) into `out`, whose images must
  // already have the right size and type (allocate()); throws std::invalid_argument otherwise.
  // Does not reallocate. Safe to call from several threads on different FrameSets.
  void render(std::int64_t frame_index, FrameSet& out) const;

  // Ground truth of every target at frame `frame_index`.
  std::vector<TargetTruth> truth(std::int64_t frame_index) const;

  // The first surface along the ray from `origin_m` (rig frame, m) in `direction` (rig frame,
  // need not be unit) at frame `frame_index`: the exact geometry the images are rendered from.
  RayTruth trace(const Eigen::Vector3d& origin_m, const Eigen::Vector3d& direction,
                 std::int64_t frame_index) const;

  // Pixels re-rendered for moving targets at this frame, summed over the four cameras (for
  // benchmarks and reports).
  std::int64_t dynamic_pixel_count(std::int64_t frame_index) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace thermovis::sim
