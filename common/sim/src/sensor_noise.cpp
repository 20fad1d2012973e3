#include "sensor_noise.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "world.hpp"

namespace thermovis::sim::detail {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNoiseScale = 16.0;  // the plane's and the sigmas' fixed point: value x16

// The noise kernels run over every pixel of every frame: on x86-64 they are also compiled for
// AVX2 and the best version is chosen when the library loads. Integer arithmetic: every
// version gives the same bytes.
#if defined(__x86_64__) && defined(__has_attribute)
#if __has_attribute(target_clones)
#define THERMOVIS_SIM_NOISE_KERNEL __attribute__((target_clones("avx2", "default")))
#endif
#endif
#ifndef THERMOVIS_SIM_NOISE_KERNEL
#define THERMOVIS_SIM_NOISE_KERNEL
#endif

// out = clamp(clean + round(z * sigma)), z = noise / 16, sigma = sigma16 / 16 (DN). In 16 bits:
// |noise * sigma16| + 128 <= 127 * 255 + 128 fits.
THERMOVIS_SIM_NOISE_KERNEL
void add_noise_u8(const std::uint8_t* clean, const std::uint8_t* sigma16, const std::int8_t* noise,
                  std::uint8_t* out, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const auto scaled = static_cast<std::int16_t>(
        static_cast<std::int16_t>(noise[i]) * static_cast<std::int16_t>(sigma16[i]) + 128);
    const auto v = static_cast<std::int16_t>(clean[i] + (scaled >> 8));
    out[i] = static_cast<std::uint8_t>(v < 0 ? 0 : (v > 255 ? 255 : v));
  }
}

// The same for infrared counts, whose sigma (under 128 counts) is one number per camera.
THERMOVIS_SIM_NOISE_KERNEL
void add_noise_u16(const std::uint16_t* clean, int sigma16, const std::int8_t* noise,
                   std::uint16_t* out, std::size_t n, int max_count) {
  for (std::size_t i = 0; i < n; ++i) {
    const int v = clean[i] + ((noise[i] * sigma16 + 128) >> 8);
    out[i] = static_cast<std::uint16_t>(std::clamp(v, 0, max_count));
  }
}

// Where row `row` of the image with noise key `key` starts reading the noise plane.
std::size_t noise_row_offset(std::uint64_t key, int row) {
  std::uint64_t state = key ^ (static_cast<std::uint64_t>(row) * 0xD6E8FEB86659FD93ULL);
  return static_cast<std::size_t>(splitmix64(state) % kNoiseOffsets);
}

}  // namespace

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  std::uint64_t state = seed ^ (a * 0xD1B54A32D192ED03ULL) ^ (b * 0x8CB92BA72F3D8DD7ULL);
  return splitmix64(state);
}

double NormalStream::next() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = (static_cast<double>(splitmix64(state_) >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(splitmix64(state_) >> 11) * 0x1.0p-53;
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(2.0 * kPi * u2);
  has_spare_ = true;
  return r * std::cos(2.0 * kPi * u2);
}

SensorNoise::SensorNoise(const Scene& scene, std::uint64_t seed, RenderOptions options)
    : seed_(seed), options_(options), infrared_(scene.infrared) {
  const VisibleExposure exposure(scene.visible);
  for (int v = 0; v < 256; ++v) {
    sigma_lut_[static_cast<std::size_t>(v)] =
        static_cast<std::uint8_t>(std::min(255L, std::lround(kNoiseScale * exposure.sigma_dn(v))));
  }
  ir_sigma16_ = static_cast<int>(
      std::lround(kNoiseScale * scene.infrared.netd_k * scene.infrared.counts_per_k));
}

void SensorNoise::draw_plane(std::size_t size) {
  plane_.resize(size);
  NormalStream normal(mix_seed(seed_, 0xA0, 0));
  for (std::int8_t& v : plane_) {
    v = static_cast<std::int8_t>(std::clamp(std::lround(kNoiseScale * normal.next()), -127L, 127L));
  }
}

void SensorNoise::draw_fixed_pattern(Slot slot, CameraLayers& c) const {
  c.fpn_offset.create(c.size, CV_32FC1);
  c.fpn_gain.create(c.size, CV_32FC1);
  if (!options_.fixed_pattern) {
    c.fpn_offset.setTo(0.0f);
    c.fpn_gain.setTo(1.0f);
    return;
  }
  NormalStream normal(mix_seed(seed_, 0xF1, static_cast<std::uint64_t>(slot)));
  std::vector<double> column(static_cast<std::size_t>(c.size.width));
  for (double& v : column) v = infrared_.fpn_column_counts * normal.next();
  for (int y = 0; y < c.size.height; ++y) {
    for (int x = 0; x < c.size.width; ++x) {
      c.fpn_offset.at<float>(y, x) = static_cast<float>(
          column[static_cast<std::size_t>(x)] + infrared_.fpn_offset_counts * normal.next());
      c.fpn_gain.at<float>(y, x) = static_cast<float>(1.0 + infrared_.fpn_gain * normal.next());
    }
  }
}

void SensorNoise::visible_sigma(const cv::Mat& clean, cv::Mat& sigma16) const {
  sigma16.create(clean.size(), CV_8UC3);
  cv::LUT(clean, sigma_lut_, sigma16);
}

std::uint64_t SensorNoise::image_key(std::int64_t frame, Slot slot) const {
  return mix_seed(seed_, static_cast<std::uint64_t>(frame), 1 + static_cast<std::uint64_t>(slot));
}

void SensorNoise::add(const CameraLayers& c, const cv::Mat& clean, const cv::Mat* sigma16,
                      cv::Rect rect, std::uint64_t key, cv::Mat& out) const {
  const std::size_t width_elems = static_cast<std::size_t>(rect.width) * c.channels;
  std::vector<std::uint8_t> sigma_row;
  for (int y = 0; y < rect.height; ++y) {
    const std::int8_t* noise = plane_.data() + noise_row_offset(key, rect.y + y) +
                               static_cast<std::size_t>(rect.x) * c.channels;
    if (c.visible) {
      const std::uint8_t* in = clean.ptr<std::uint8_t>(y);
      std::uint8_t* dst = out.ptr<std::uint8_t>(rect.y + y) + rect.x * 3;
      if (!options_.temporal_noise) {
        std::copy(in, in + width_elems, dst);
        continue;
      }
      const std::uint8_t* s = nullptr;
      if (sigma16 != nullptr) {
        s = sigma16->ptr<std::uint8_t>(y);
      } else {
        sigma_row.resize(width_elems);
        for (std::size_t i = 0; i < width_elems; ++i) sigma_row[i] = sigma_lut_[in[i]];
        s = sigma_row.data();
      }
      add_noise_u8(in, s, noise, dst, width_elems);
    } else {
      const std::uint16_t* in = clean.ptr<std::uint16_t>(y);
      std::uint16_t* dst = out.ptr<std::uint16_t>(rect.y + y) + rect.x;
      if (!options_.temporal_noise) {
        std::copy(in, in + width_elems, dst);
        continue;
      }
      add_noise_u16(in, ir_sigma16_, noise, dst, width_elems, c.max_count());
    }
  }
}

}  // namespace thermovis::sim::detail
