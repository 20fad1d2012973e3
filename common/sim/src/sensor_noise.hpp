#pragma once
// Internal: the simulated cameras' sensor noise. Temporal noise (visible shot and read noise,
// infrared NETD noise) is read from one plane of normal samples N(0, 1), stored as round(16 z)
// in int8 (|z| < 8): each row of each image reads a run of it that starts at its own
// pseudo-random offset in [0, kNoiseOffsets), drawn from (seed, frame, camera, row), so no two
// images' noise fields are shifted copies of each other (which a matcher would see as a false
// match at that shift), and the plane is small enough to stay in cache while every image is
// written. Infrared fixed-pattern noise (offset and gain per pixel, offset per column) is drawn
// once per camera. Everything follows from the seed: the same on every platform.
#include <array>
#include <cstddef>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "camera_layers.hpp"
#include "thermovis/sim/scene.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::sim::detail {

inline constexpr std::size_t kNoiseOffsets = std::size_t{1} << 20;

// splitmix64: advances `state` and returns the next 64 pseudo-random bits.
std::uint64_t splitmix64(std::uint64_t& state);
// A seed derived from `seed` and two stream numbers.
std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b);

// Deterministic standard normal samples (Box-Muller on splitmix64), the same on every platform.
class NormalStream {
 public:
  explicit NormalStream(std::uint64_t seed) : state_(seed) {}
  double next();

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

class SensorNoise {
 public:
  SensorNoise(const Scene& scene, std::uint64_t seed, RenderOptions options);

  // The noise plane's length for images whose longest row holds `row_elements` samples (width
  // x channels).
  static std::size_t plane_size(std::size_t row_elements) { return kNoiseOffsets + row_elements; }
  // Draws the plane (of plane_size()) from the seed.
  void draw_plane(std::size_t size);
  // The plane, for the static cache to store or restore.
  std::vector<std::int8_t>& plane() { return plane_; }
  const std::vector<std::int8_t>& plane() const { return plane_; }

  // The infrared camera's fixed-pattern offset and gain (CV_32FC1 layers of `c`); zero offset
  // and unit gain when the option is off.
  void draw_fixed_pattern(Slot slot, CameraLayers& c) const;
  // Visible: the noise sigma x16 (DN) of each value of a CV_8UC3 noise-free image.
  void visible_sigma(const cv::Mat& clean, cv::Mat& sigma16) const;

  // The key of one image's noise: frame and camera.
  std::uint64_t image_key(std::int64_t frame, Slot slot) const;
  // Temporal noise over `clean` (the noise-free pixels of `rect` of camera c's image, or the
  // whole image) written to `rect` of `out` (the image). `sigma16`: visible_sigma() of `clean`
  // when at hand, else nullptr (computed per row).
  void add(const CameraLayers& c, const cv::Mat& clean, const cv::Mat* sigma16, cv::Rect rect,
           std::uint64_t key, cv::Mat& out) const;

 private:
  std::uint64_t seed_;
  RenderOptions options_;
  InfraredBand infrared_;
  std::vector<std::int8_t> plane_;
  std::array<std::uint8_t, 256> sigma_lut_{};  // visible: sigma x16 per clean DN
  int ir_sigma16_ = 0;                         // infrared: sigma x16, counts
};

}  // namespace thermovis::sim::detail
