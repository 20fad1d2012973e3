#include "thermovis/sim/simulated_rig.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "world.hpp"

namespace thermovis::sim {
namespace {

using detail::Hit;
using detail::PlacedTarget;

constexpr double kPi = 3.14159265358979323846;
constexpr int kSuperSamples = 4;        // per axis, at static edges: coverage to 1/16 of a pixel
constexpr int kMovingSuperSamples = 3;  // per axis, at moving targets' edges (per frame: cheaper)
constexpr int kRegionPad = 2;           // px around a moving target's projected box
// Noise: one plane of normal samples N(0, 1) stored as round(16 z) in int8 (|z| < 8). Each row
// of each image reads a run of it that starts at its own pseudo-random offset in
// [0, kNoiseOffsets), drawn from (seed, frame, camera, row): no two images' noise fields are
// shifted copies of each other (which the matcher would see as a false match at that shift),
// and the plane is small enough to stay in cache while every image is written.
constexpr std::size_t kNoiseOffsets = std::size_t{1} << 20;
constexpr double kNoiseScale = 16.0;

std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// Deterministic standard normal samples (Box-Muller on splitmix64), the same on every platform.
class NormalStream {
 public:
  explicit NormalStream(std::uint64_t seed) : state_(seed) {}
  double next() {
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

 private:
  std::uint64_t state_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

std::uint64_t mix_seed(std::uint64_t seed, std::uint64_t a, std::uint64_t b) {
  std::uint64_t state = seed ^ (a * 0xD1B54A32D192ED03ULL) ^ (b * 0x8CB92BA72F3D8DD7ULL);
  return splitmix64(state);
}

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

// Linear value of a ray: visible DN per channel (B, G, R), or infrared signal counts in [0].
using Linear = cv::Vec3f;

struct CameraCache {
  const camera::RigCamera* camera = nullptr;
  bool visible = true;
  cv::Size size;
  int channels = 3;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // world frame, m
  Eigen::Matrix3d R_world_cam = Eigen::Matrix3d::Identity();
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  double pixel_angle_rad = 1e-3;
  cv::Mat rays;                  // CV_32FC3, unit rays in the world frame (NaN: no ray)
  cv::Mat static_depth;          // CV_32FC1, m along the ray (inf: sky)
  cv::Mat static_id;             // CV_16UC1
  cv::Mat static_linear;         // CV_32FC3 (visible DN, before blur) or CV_32FC1 (infrared signal)
  cv::Mat static_clean;          // CV_8UC3 or CV_16UC1: the noise-free image of the static scene
  cv::Mat static_sigma;          // CV_8UC3: visible noise sigma x16 of static_clean
  cv::Mat fpn_offset, fpn_gain;  // CV_32FC1, infrared
};

// What the set-up computes for one camera, in the cache file's order: rays, depth, surface id,
// linear values, the noise-free image, then (visible) its noise sigma or (infrared) the
// fixed-pattern offset and gain.
std::vector<cv::Mat*> cached_layers(CameraCache& c) {
  std::vector<cv::Mat*> layers{&c.rays, &c.static_depth, &c.static_id, &c.static_linear,
                               &c.static_clean};
  if (c.visible) {
    layers.push_back(&c.static_sigma);
  } else {
    layers.push_back(&c.fpn_offset);
    layers.push_back(&c.fpn_gain);
  }
  return layers;
}
std::vector<int> cached_types(const CameraCache& c) {
  if (c.visible) return {CV_32FC3, CV_32FC1, CV_16UC1, CV_32FC3, CV_8UC3, CV_8UC3};
  return {CV_32FC3, CV_32FC1, CV_16UC1, CV_32FC1, CV_16UC1, CV_32FC1, CV_32FC1};
}

// Cache file: a header of kCacheHeader bytes (magic, key length (u64) and key, per camera its
// width and height and the OpenCV type of each layer (i32), the noise plane's length (u64)),
// then each camera's layers and the noise plane, each starting on a kCacheAlign boundary. Read
// by mapping it: the pages of the file are the images, and only the pixels used are ever read.
constexpr char kCacheMagic[8] = {'T', 'V', 'S', 'T', 'A', 'T', 'I', '3'};
constexpr std::size_t kCacheHeader = 8192;
constexpr std::size_t kCacheAlign = 64;
constexpr std::size_t kMaxKey = 4096;

std::size_t aligned(std::size_t n) { return (n + kCacheAlign - 1) / kCacheAlign * kCacheAlign; }

// Writes the cameras' set-up and the noise plane to `file` (through a temporary file renamed
// over it); "" or why not.
std::string write_static(const std::filesystem::path& file, const std::string& key,
                         std::array<CameraCache, kSlotCount>& cams,
                         const std::vector<std::int8_t>& noise_plane) {
  if (key.size() > kMaxKey) return "cache key over " + std::to_string(kMaxKey) + " bytes";
  std::error_code error;
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path(), error);
  const std::filesystem::path temporary =
      file.string() + ".tmp." + std::to_string(static_cast<long>(::getpid()));
  {
    std::string header(kCacheHeader, '\0');
    std::size_t at = 0;
    const auto put = [&header, &at](const void* data, std::size_t n) {
      std::memcpy(header.data() + at, data, n);
      at += n;
    };
    put(kCacheMagic, sizeof kCacheMagic);
    const std::uint64_t key_size = key.size();
    put(&key_size, sizeof key_size);
    put(key.data(), key.size());
    for (CameraCache& c : cams) {
      const std::int32_t size[2] = {c.size.width, c.size.height};
      put(size, sizeof size);
      for (const cv::Mat* m : cached_layers(c)) {
        const std::int32_t type = m->type();
        put(&type, sizeof type);
      }
    }
    const std::uint64_t plane = noise_plane.size();
    put(&plane, sizeof plane);
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) return "cannot write " + temporary.string();
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    const char padding[kCacheAlign] = {};
    const auto block = [&out, &padding](const void* data, std::size_t bytes) {
      out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
      out.write(padding, static_cast<std::streamsize>(aligned(bytes) - bytes));
    };
    for (CameraCache& c : cams) {
      for (const cv::Mat* m : cached_layers(c)) block(m->ptr(), m->total() * m->elemSize());
    }
    block(noise_plane.data(), noise_plane.size());
    if (!out.flush()) {
      out.close();
      std::filesystem::remove(temporary, error);
      return "cannot write " + temporary.string() + " (disk full?)";
    }
  }
  std::filesystem::rename(temporary, file, error);
  if (error) {
    std::filesystem::remove(temporary, error);
    return "cannot rename " + temporary.string() + " to " + file.string();
  }
  return "";
}

// Maps `file` when it holds `key` and the layers of `cams` (whose sizes and bands are set) and
// points their layers into it, and copies the noise plane (of `plane_size`); "" or why not.
// `mapping` keeps the mapping for as long as the images are used.
std::string read_static(const std::filesystem::path& file, const std::string& key,
                        std::array<CameraCache, kSlotCount>& cams, std::size_t plane_size,
                        std::vector<std::int8_t>& noise_plane, std::shared_ptr<void>& mapping) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "no cache file " + file.string() + " yet";
  struct stat st {};
  const bool stated = ::fstat(fd, &st) == 0;
  const auto length = stated ? static_cast<std::size_t>(st.st_size) : 0;
  // Private and writable: the images are only read, but nothing written could reach the file.
  void* base = length >= kCacheHeader
                   ? ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE, fd, 0)
                   : MAP_FAILED;
  ::close(fd);
  const std::string what = "cache file " + file.string();
  if (base == MAP_FAILED) return what + " is not a static scene cache (too short)";
  mapping = std::shared_ptr<void>(base, [length](void* p) { ::munmap(p, length); });
  auto* bytes = static_cast<std::uint8_t*>(base);
  std::size_t at = 0;
  const auto get = [bytes, &at](void* out, std::size_t n) {
    std::memcpy(out, bytes + at, n);
    at += n;
  };
  char magic[sizeof kCacheMagic];
  std::uint64_t key_size = 0;
  get(magic, sizeof magic);
  get(&key_size, sizeof key_size);
  if (std::memcmp(magic, kCacheMagic, sizeof magic) != 0 || key_size > kMaxKey)
    return what + " is not a static scene cache";
  if (key_size != key.size() || std::memcmp(bytes + at, key.data(), key.size()) != 0)
    return what + " is for another rig, scene, seed or build";
  at += key.size();
  std::size_t data = kCacheHeader;
  for (int i = 0; i < kSlotCount; ++i) {
    CameraCache& c = cams[static_cast<std::size_t>(i)];
    std::int32_t stored[2] = {0, 0};
    get(stored, sizeof stored);
    if (stored[0] != c.size.width || stored[1] != c.size.height)
      return what + ": " + to_string(static_cast<Slot>(i)) + " is not the rig's size";
    const std::vector<int> types = cached_types(c);
    const std::vector<cv::Mat*> layers = cached_layers(c);
    for (std::size_t k = 0; k < layers.size(); ++k) {
      std::int32_t type = -1;
      get(&type, sizeof type);
      if (type != types[k])
        return what + ": " + to_string(static_cast<Slot>(i)) + " has a wrong layer type";
      const std::size_t n =
          static_cast<std::size_t>(c.size.area()) * static_cast<std::size_t>(CV_ELEM_SIZE(type));
      if (data + n > length) return what + " is truncated";
      *layers[k] = cv::Mat(c.size, type, bytes + data);
      data += aligned(n);
    }
  }
  std::uint64_t plane = 0;
  get(&plane, sizeof plane);
  if (plane != plane_size) return what + ": the noise plane is not this rig's";
  if (data + plane > length) return what + " is truncated";
  noise_plane.assign(reinterpret_cast<const std::int8_t*>(bytes + data),
                     reinterpret_cast<const std::int8_t*>(bytes + data + plane));
  data += aligned(plane);
  if (data != length) return what + " is truncated or too long";
  return "";
}

}  // namespace

const char* to_string(Slot slot) {
  switch (slot) {
    case Slot::visible_left:
      return "visible_left";
    case Slot::visible_right:
      return "visible_right";
    case Slot::infrared_left:
      return "infrared_left";
    case Slot::infrared_right:
      return "infrared_right";
  }
  return "unknown";
}

struct SimulatedRig::Impl {
  camera::Rig rig;
  Scene scene;
  std::uint64_t seed = 0;
  RenderOptions options;
  std::unique_ptr<detail::World> world;
  detail::VisibleExposure exposure;
  detail::InfraredTransfer ir_transfer;
  std::array<CameraCache, kSlotCount> cams;
  std::vector<detail::PlacedTarget> static_targets;
  std::vector<std::vector<Eigen::Vector3d>> hull_points;  // per target, local frame
  std::vector<std::int8_t> noise_plane;
  std::array<std::uint8_t, 256> sigma_lut{};  // visible: sigma x16 per clean DN
  int ir_sigma16 = 0;
  Eigen::Isometry3d T_visible_left_world = Eigen::Isometry3d::Identity();
  float sky_counts = 0.0f;
  StaticSetup static_setup;
  std::shared_ptr<void> static_mapping;  // the cache file the static layers point into

  Impl(camera::Rig r, Scene s, std::uint64_t sd, RenderOptions opt)
      : rig(std::move(r)),
        scene(std::move(s)),
        seed(sd),
        options(opt),
        exposure(scene.visible),
        ir_transfer(scene.infrared) {}

  int max_count(const CameraCache& c) const { return (1 << c.camera->bit_depth) - 1; }

  bool is_moving_id(std::uint16_t id) const {
    if (id < detail::kFirstTargetId || id == detail::kNoRayId) return false;
    const std::size_t i = id - detail::kFirstTargetId;
    return i < world->targets().size() && world->targets()[i].spec.moving();
  }

  Linear radiance(const CameraCache& c, const Hit& hit, const Eigen::Vector3d& d) const {
    if (hit.texture < 0) {  // sky
      if (!c.visible) return {sky_counts, 0.0f, 0.0f};
      const Eigen::Vector3f sky = (scene.visible.sky_colour * exposure.white_dn).cast<float>();
      return {sky.x(), sky.y(), sky.z()};
    }
    const detail::SurfaceSample s = world->shade(hit, d, c.pixel_angle_rad);
    if (!c.visible) return {ir_transfer.counts(s.temperature_c), 0.0f, 0.0f};
    // Uniform textures are self-luminous (markers, lamps): not shaded by the sun.
    const bool shaded =
        scene.textures[static_cast<std::size_t>(hit.texture)].pattern != TexturePattern::uniform;
    const float k = (shaded ? detail::World::lighting(hit.normal) : 1.0f) *
                    static_cast<float>(exposure.white_dn);
    return {k * s.reflectance_bgr.x(), k * s.reflectance_bgr.y(), k * s.reflectance_bgr.z()};
  }

  // The static scene along one ray.
  Linear trace_static(const CameraCache& c, const Eigen::Vector3d& d, Hit& hit) const {
    world->trace_background(c.centre, d, hit);
    detail::World::trace_targets(static_targets, c.centre, d, hit);
    return radiance(c, hit, d);
  }

  // Mean of the static scene over kSuperSamples^2 rays spread over the pixel's area.
  Linear supersample_static(const CameraCache& c, int x, int y) const {
    Linear sum(0.0f, 0.0f, 0.0f);
    int count = 0;
    for (int j = 0; j < kSuperSamples; ++j) {
      for (int i = 0; i < kSuperSamples; ++i) {
        const Eigen::Vector2d px(x - 0.5 + (i + 0.5) / kSuperSamples,
                                 y - 0.5 + (j + 0.5) / kSuperSamples);
        Eigen::Vector3d ray;
        if (!c.camera->model->unproject(px, ray)) continue;
        Hit hit;
        sum += trace_static(c, c.R_world_cam * ray.normalized(), hit);
        ++count;
      }
    }
    return count > 0 ? sum * (1.0f / static_cast<float>(count)) : sum;
  }

  // The ray through image point (px, py), bilinear between the precomputed pixel rays (the ray
  // field is smooth: the error is far below a hundredth of a pixel); exact where a neighbour
  // has no ray.
  Eigen::Vector3d ray_at(const CameraCache& c, double px, double py) const {
    const int x0 = std::clamp(static_cast<int>(std::floor(px)), 0, c.size.width - 2);
    const int y0 = std::clamp(static_cast<int>(std::floor(py)), 0, c.size.height - 2);
    const float fx = static_cast<float>(px - x0), fy = static_cast<float>(py - y0);
    const float gx = 1.0f - fx, gy = 1.0f - fy;
    const float* a = c.rays.ptr<float>(y0) + 3 * x0;      // then b = a + 3
    const float* d = c.rays.ptr<float>(y0 + 1) + 3 * x0;  // then e = d + 3
    float r[3];
    for (int k = 0; k < 3; ++k)
      r[k] = (a[k] * gx + a[k + 3] * fx) * gy + (d[k] * gx + d[k + 3] * fx) * fy;
    if (std::isnan(r[0])) {
      Eigen::Vector3d ray;
      if (!c.camera->model->unproject(Eigen::Vector2d(px, py), ray))
        return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
      return c.R_world_cam * ray.normalized();
    }
    // Not renormalised: between neighbouring unit rays the interpolated length is 1 to within
    // 1e-6 (like the float pixel rays' 1e-7), and every intersection takes any length.
    return {r[0], r[1], r[2]};
  }

  // Anti-aliasing of a moving target's edge pixel: kMovingSuperSamples^2 rays against the moving
  // targets; the rays that miss them see the static scene, whose pixel value (already
  // anti-aliased) stands for it. Each target part is shaded once per pixel.
  Linear supersample_moving(const CameraCache& c, int x, int y,
                            const std::vector<const detail::PreparedTarget*>& moving,
                            const Linear& static_value) const {
    const double depth = c.static_depth.at<float>(y, x);
    Linear sum(0.0f, 0.0f, 0.0f);
    int count = 0;
    int shaded_texture = -1;
    std::uint16_t shaded_id = detail::kNoRayId;
    Linear shaded(0.0f, 0.0f, 0.0f);
    for (int j = 0; j < kMovingSuperSamples; ++j) {
      for (int i = 0; i < kMovingSuperSamples; ++i) {
        const Eigen::Vector3d d = ray_at(c, x - 0.5 + (i + 0.5) / kMovingSuperSamples,
                                         y - 0.5 + (j + 0.5) / kMovingSuperSamples);
        if (std::isnan(d.x())) continue;
        ++count;
        Hit hit;
        hit.t = depth;
        for (const detail::PreparedTarget* pt : moving) detail::World::trace_target(*pt, d, hit);
        if (hit.texture < 0) {
          sum += static_value;
          continue;
        }
        if (hit.id != shaded_id || hit.texture != shaded_texture) {
          shaded = radiance(c, hit, d);
          shaded_id = hit.id;
          shaded_texture = hit.texture;
        }
        sum += shaded;
      }
    }
    return count > 0 ? sum * (1.0f / static_cast<float>(count)) : static_value;
  }

  // Each pixel's ray, and the static scene along it: depth, surface id and linear value,
  // supersampled at edges.
  void trace_static_scene(CameraCache& c, const camera::RigCamera& cam) const {
    const int linear_type = c.visible ? CV_32FC3 : CV_32FC1;
    c.rays.create(c.size, CV_32FC3);
    c.static_depth.create(c.size, CV_32FC1);
    c.static_id.create(c.size, CV_16UC1);
    c.static_linear.create(c.size, linear_type);
    cv::parallel_for_(cv::Range(0, c.size.height), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y) {
        for (int x = 0; x < c.size.width; ++x) {
          Eigen::Vector3d ray;
          auto& r = c.rays.at<cv::Vec3f>(y, x);
          if (!cam.model->unproject(Eigen::Vector2d(x, y), ray)) {
            r = cv::Vec3f(NAN, NAN, NAN);
            c.static_depth.at<float>(y, x) = 0.0f;
            c.static_id.at<std::uint16_t>(y, x) = detail::kNoRayId;
            set_linear(c.static_linear, y, x, Linear(0.0f, 0.0f, 0.0f));
            continue;
          }
          const Eigen::Vector3d d = c.R_world_cam * ray.normalized();
          r = cv::Vec3f(static_cast<float>(d.x()), static_cast<float>(d.y()),
                        static_cast<float>(d.z()));
          Hit hit;
          set_linear(c.static_linear, y, x, trace_static(c, d, hit));
          c.static_depth.at<float>(y, x) = static_cast<float>(hit.t);
          c.static_id.at<std::uint16_t>(y, x) = hit.id;
        }
      }
    });
    // Anti-aliasing: supersample the pixels on an edge between two things.
    cv::parallel_for_(cv::Range(0, c.size.height), [&](const cv::Range& rows) {
      for (int y = rows.start; y < rows.end; ++y) {
        for (int x = 0; x < c.size.width; ++x) {
          if (on_edge(c.static_id, y, x, c.static_id, cv::Point(0, 0)))
            set_linear(c.static_linear, y, x, supersample_static(c, x, y));
        }
      }
    });
  }

  // The camera's geometry: size, band, pose, the angle of a pixel.
  void set_geometry(Slot slot, const camera::RigCamera& cam) {
    CameraCache& c = cams[static_cast<int>(slot)];
    c.camera = &cam;
    c.visible = slot == Slot::visible_left || slot == Slot::visible_right;
    c.size = cam.model->image_size();
    c.channels = c.visible ? 3 : 1;
    c.centre = cam.T_ref_cam.translation();
    c.R_world_cam = cam.T_ref_cam.linear();
    c.T_cam_world = cam.T_ref_cam.inverse();
    {  // angle of one pixel at the image centre, for texture level of detail
      Eigen::Vector3d a, b;
      const Eigen::Vector2d mid(c.size.width / 2.0, c.size.height / 2.0);
      if (cam.model->unproject(mid, a) && cam.model->unproject(mid + Eigen::Vector2d(1, 0), b))
        c.pixel_angle_rad = std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
    }
  }

  // The camera's rays and static images (set_geometry first): the static scene traced, its
  // noise-free image, the fixed-pattern noise.
  void build_camera(Slot slot) {
    CameraCache& c = cams[static_cast<int>(slot)];
    trace_static_scene(c, *c.camera);
    if (!c.visible) build_fixed_pattern(slot, c);
    c.static_clean.create(c.size, c.visible ? CV_8UC3 : CV_16UC1);
    finish(c, c.static_linear, cv::Rect(cv::Point(0, 0), c.size), c.static_clean, true);
    if (c.visible) {
      c.static_sigma.create(c.size, CV_8UC3);
      cv::LUT(c.static_clean, sigma_lut, c.static_sigma);
    }
  }

  static void set_linear(cv::Mat& m, int y, int x, const Linear& v) {
    if (m.channels() == 3) {
      m.at<cv::Vec3f>(y, x) = v;
    } else {
      m.at<float>(y, x) = v[0];
    }
  }
  static Linear get_linear(const cv::Mat& m, int y, int x) {
    if (m.channels() == 3) return m.at<cv::Vec3f>(y, x);
    return {m.at<float>(y, x), 0.0f, 0.0f};
  }

  // True when pixel (y, x) of `ids` (whose top-left is `origin` in the image) has a 4-neighbour
  // with another id; neighbours outside `ids` are read from the full-image `static_ids`.
  static bool on_edge(const cv::Mat& ids, int y, int x, const cv::Mat& static_ids,
                      cv::Point origin) {
    const std::uint16_t id = ids.at<std::uint16_t>(y, x);
    if (id == detail::kNoRayId) return false;
    constexpr int dx[4] = {1, -1, 0, 0}, dy[4] = {0, 0, 1, -1};
    for (int k = 0; k < 4; ++k) {
      const int nx = x + dx[k], ny = y + dy[k];
      std::uint16_t other = id;
      if (nx >= 0 && ny >= 0 && nx < ids.cols && ny < ids.rows) {
        other = ids.at<std::uint16_t>(ny, nx);
      } else {
        const int gx = nx + origin.x, gy = ny + origin.y;
        if (gx >= 0 && gy >= 0 && gx < static_ids.cols && gy < static_ids.rows)
          other = static_ids.at<std::uint16_t>(gy, gx);
      }
      if (other != id && other != detail::kNoRayId) return true;
    }
    return false;
  }

  void build_fixed_pattern(Slot slot, CameraCache& c) {
    c.fpn_offset.create(c.size, CV_32FC1);
    c.fpn_gain.create(c.size, CV_32FC1);
    if (!options.fixed_pattern) {
      c.fpn_offset.setTo(0.0f);
      c.fpn_gain.setTo(1.0f);
      return;
    }
    NormalStream normal(mix_seed(seed, 0xF1, static_cast<std::uint64_t>(slot)));
    std::vector<double> column(static_cast<std::size_t>(c.size.width));
    for (double& v : column) v = scene.infrared.fpn_column_counts * normal.next();
    for (int y = 0; y < c.size.height; ++y) {
      for (int x = 0; x < c.size.width; ++x) {
        c.fpn_offset.at<float>(y, x) = static_cast<float>(
            column[static_cast<std::size_t>(x)] + scene.infrared.fpn_offset_counts * normal.next());
        c.fpn_gain.at<float>(y, x) =
            static_cast<float>(1.0 + scene.infrared.fpn_gain * normal.next());
      }
    }
  }

  // Linear values of `rect` (image coordinates; `linear` and `clean` hold just that rectangle)
  // -> the noise-free raw image; `blur` applies the visible optical blur first.
  void finish(const CameraCache& c, const cv::Mat& linear, cv::Rect rect, cv::Mat& clean,
              bool blur) const {
    if (c.visible) {
      const double sigma = scene.visible.blur_sigma_px;
      if (blur && sigma > 0.0) {
        cv::Mat blurred;
        cv::GaussianBlur(linear, blurred, cv::Size(0, 0), sigma, sigma, cv::BORDER_REPLICATE);
        blurred.convertTo(clean, CV_8UC3);
      } else {
        linear.convertTo(clean, CV_8UC3);
      }
      return;
    }
    const float ref = static_cast<float>(scene.infrared.counts_at_20c);
    const auto top = static_cast<float>(max_count(c));
    for (int y = 0; y < rect.height; ++y) {
      const float* in = linear.ptr<float>(y);
      const float* offset = c.fpn_offset.ptr<float>(rect.y + y) + rect.x;
      const float* gain = c.fpn_gain.ptr<float>(rect.y + y) + rect.x;
      auto* out = clean.ptr<std::uint16_t>(y);
      for (int x = 0; x < rect.width; ++x) {
        const float counts = ref + gain[x] * (in[x] - ref) + offset[x];
        out[x] = static_cast<std::uint16_t>(std::lround(std::clamp(counts, 0.0f, top)));
      }
    }
  }

  // The key of one image's noise: frame and camera.
  std::uint64_t noise_key(std::int64_t frame, Slot slot) const {
    return mix_seed(seed, static_cast<std::uint64_t>(frame), 1 + static_cast<std::uint64_t>(slot));
  }

  // Where row `row` of the image with noise key `key` starts reading the noise plane.
  static std::size_t noise_row_offset(std::uint64_t key, int row) {
    std::uint64_t state = key ^ (static_cast<std::uint64_t>(row) * 0xD6E8FEB86659FD93ULL);
    return static_cast<std::size_t>(splitmix64(state) % kNoiseOffsets);
  }

  // Noise over rows of `clean` (a rect of the image, or the whole image) into `out` (the image).
  void add_noise(const CameraCache& c, const cv::Mat& clean, const cv::Mat* sigma, cv::Rect rect,
                 std::uint64_t key, cv::Mat& out) const {
    const std::size_t width_elems = static_cast<std::size_t>(rect.width) * c.channels;
    std::vector<std::uint8_t> sigma_row;
    for (int y = 0; y < rect.height; ++y) {
      const std::int8_t* noise = noise_plane.data() + noise_row_offset(key, rect.y + y) +
                                 static_cast<std::size_t>(rect.x) * c.channels;
      if (c.visible) {
        const std::uint8_t* in = clean.ptr<std::uint8_t>(y);
        std::uint8_t* dst = out.ptr<std::uint8_t>(rect.y + y) + rect.x * 3;
        if (!options.temporal_noise) {
          std::copy(in, in + width_elems, dst);
          continue;
        }
        const std::uint8_t* s = nullptr;
        if (sigma != nullptr) {
          s = sigma->ptr<std::uint8_t>(y);
        } else {
          sigma_row.resize(width_elems);
          for (std::size_t i = 0; i < width_elems; ++i) sigma_row[i] = sigma_lut[in[i]];
          s = sigma_row.data();
        }
        add_noise_u8(in, s, noise, dst, width_elems);
      } else {
        const std::uint16_t* in = clean.ptr<std::uint16_t>(y);
        std::uint16_t* dst = out.ptr<std::uint16_t>(rect.y + y) + rect.x;
        if (!options.temporal_noise) {
          std::copy(in, in + width_elems, dst);
          continue;
        }
        add_noise_u16(in, ir_sigma16, noise, dst, width_elems, max_count(c));
      }
    }
  }

  std::vector<Eigen::Vector3d> hull_of(const detail::CompiledTarget& t) const {
    // Corners of the local bounding box and 4 points along each edge: the projected extent of
    // a box whose edges the lens bends.
    std::vector<Eigen::Vector3d> pts;
    const Eigen::Vector3d lo = t.bound_lo, hi = t.bound_hi;
    for (int i = 0; i <= 5; ++i) {
      for (int j = 0; j <= 5; ++j) {
        for (int k = 0; k <= 5; ++k) {
          const int ends = (i % 5 == 0) + (j % 5 == 0) + (k % 5 == 0);
          if (ends < 2) continue;  // corners and edges only
          const Eigen::Vector3d f(i / 5.0, j / 5.0, k / 5.0);
          pts.push_back(lo + (hi - lo).cwiseProduct(f));
        }
      }
    }
    return pts;
  }

  // Extent in camera c's image of a target's local points placed at `foot`, or nothing when no
  // point is in the lens's field. Points beyond the field stretch the extent to the image border
  // on their side (the target reaches past it). Not clipped to the image.
  std::optional<TruthBox> projected_extent(const CameraCache& c,
                                           const std::vector<Eigen::Vector3d>& points,
                                           const detail::CompiledTarget& target,
                                           const Eigen::Vector3d& foot) const {
    TruthBox box{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                 -std::numeric_limits<double>::infinity(),
                 -std::numeric_limits<double>::infinity()};
    bool any_valid = false;
    bool beyond_left = false, beyond_right = false, beyond_top = false, beyond_bottom = false;
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d ray = c.T_cam_world * (foot + target.R_world_local * p);
      Eigen::Vector2d px;
      if (!c.camera->model->project(ray, px)) {
        beyond_left = beyond_left || ray.x() < 0.0;
        beyond_right = beyond_right || ray.x() > 0.0;
        beyond_top = beyond_top || ray.y() < 0.0;
        beyond_bottom = beyond_bottom || ray.y() > 0.0;
        continue;
      }
      any_valid = true;
      box.x_min = std::min(box.x_min, px.x());
      box.y_min = std::min(box.y_min, px.y());
      box.x_max = std::max(box.x_max, px.x());
      box.y_max = std::max(box.y_max, px.y());
    }
    if (!any_valid) return std::nullopt;
    if (beyond_left) box.x_min = -0.5;
    if (beyond_right) box.x_max = c.size.width - 0.5;
    if (beyond_top) box.y_min = -0.5;
    if (beyond_bottom) box.y_max = c.size.height - 0.5;
    return box;
  }

  // The image rectangle a placed target may cover in camera c (with a margin), or an empty one.
  cv::Rect target_region(const CameraCache& c, const PlacedTarget& pt) const {
    const std::size_t index = pt.target->id - detail::kFirstTargetId;
    const auto extent = projected_extent(c, hull_points[index], *pt.target, pt.foot);
    if (!extent) return {};
    const int margin = kRegionPad + blur_radius(c);
    const cv::Rect box(cv::Point(static_cast<int>(std::floor(extent->x_min)) - margin,
                                 static_cast<int>(std::floor(extent->y_min)) - margin),
                       cv::Point(static_cast<int>(std::ceil(extent->x_max)) + margin + 1,
                                 static_cast<int>(std::ceil(extent->y_max)) + margin + 1));
    return box & cv::Rect(cv::Point(0, 0), c.size);
  }

  int blur_radius(const CameraCache& c) const {
    if (!c.visible || scene.visible.blur_sigma_px <= 0.0) return 0;
    return static_cast<int>(std::ceil(4.0 * scene.visible.blur_sigma_px));
  }

  // The prepared targets whose region (`regions`, image coordinates) holds pixel (x, y): the
  // only ones its rays can meet, since a region holds its target's projection with a margin.
  static void covering(const std::vector<detail::PreparedTarget>& prepared,
                       const std::vector<cv::Rect>& regions, int x, int y,
                       std::vector<const detail::PreparedTarget*>& out) {
    out.clear();
    for (std::size_t k = 0; k < prepared.size(); ++k) {
      if (regions[k].contains(cv::Point(x, y))) out.push_back(&prepared[k]);
    }
  }

  // Re-renders `out_rect` of camera c with the moving targets (whose regions are
  // `moving_regions`) and writes it (with noise) to out.
  void render_region(const CameraCache& c, cv::Rect out_rect,
                     const std::vector<PlacedTarget>& moving,
                     const std::vector<cv::Rect>& moving_regions, std::uint64_t noise_key,
                     cv::Mat& out) const {
    const int rb = blur_radius(c);
    const cv::Rect image(cv::Point(0, 0), c.size);
    const cv::Rect rr = cv::Rect(out_rect.x - rb, out_rect.y - rb, out_rect.width + 2 * rb,
                                 out_rect.height + 2 * rb) &
                        image;
    const std::vector<detail::PreparedTarget> prepared = detail::World::prepare(moving, c.centre);
    std::vector<const detail::PreparedTarget*> near;
    near.reserve(prepared.size());
    cv::Mat linear, ids;
    c.static_linear(rr).copyTo(linear);
    c.static_id(rr).copyTo(ids);
    for (int y = 0; y < rr.height; ++y) {
      const int gy = rr.y + y;
      const auto* static_id = c.static_id.ptr<std::uint16_t>(gy) + rr.x;
      const float* depth = c.static_depth.ptr<float>(gy) + rr.x;
      const float* ray = c.rays.ptr<float>(gy) + 3 * rr.x;
      auto* id = ids.ptr<std::uint16_t>(y);
      for (int x = 0; x < rr.width; ++x) {
        if (static_id[x] == detail::kNoRayId) continue;
        covering(prepared, moving_regions, rr.x + x, gy, near);
        if (near.empty()) continue;
        const Eigen::Vector3d d(ray[3 * x], ray[3 * x + 1], ray[3 * x + 2]);
        Hit hit;
        hit.t = depth[x];
        for (const detail::PreparedTarget* pt : near) detail::World::trace_target(*pt, d, hit);
        if (hit.texture < 0) continue;  // no moving target in front of the static scene
        id[x] = hit.id;
        set_linear(linear, y, x, radiance(c, hit, d));
      }
    }
    for (int y = 0; y < rr.height; ++y) {
      for (int x = 0; x < rr.width; ++x) {
        if (!on_edge(ids, y, x, c.static_id, rr.tl())) continue;
        // Only edges that involve a moving target changed; static edges are already smooth.
        const std::uint16_t id = ids.at<std::uint16_t>(y, x);
        bool involves_moving = is_moving_id(id);
        for (const cv::Point n :
             {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
          const int nx = x + n.x, ny = y + n.y;
          if (nx >= 0 && ny >= 0 && nx < rr.width && ny < rr.height)
            involves_moving = involves_moving || is_moving_id(ids.at<std::uint16_t>(ny, nx));
        }
        if (involves_moving) {
          covering(prepared, moving_regions, rr.x + x, rr.y + y, near);
          set_linear(linear, y, x,
                     supersample_moving(c, rr.x + x, rr.y + y, near,
                                        get_linear(c.static_linear, rr.y + y, rr.x + x)));
        }
      }
    }
    cv::Mat finished = linear;
    if (rb > 0) {
      cv::GaussianBlur(linear, finished, cv::Size(0, 0), scene.visible.blur_sigma_px,
                       scene.visible.blur_sigma_px, cv::BORDER_REPLICATE);
    }
    const cv::Rect inner = out_rect - rr.tl();
    cv::Mat clean(out_rect.size(), c.visible ? CV_8UC3 : CV_16UC1);
    finish(c, finished(inner), out_rect, clean, false);
    add_noise(c, clean, nullptr, out_rect, noise_key, out);
  }

  // One region per moving target (empty where it is out of the image).
  std::vector<cv::Rect> regions(const CameraCache& c,
                                const std::vector<PlacedTarget>& moving) const {
    std::vector<cv::Rect> out;
    for (const PlacedTarget& pt : moving) out.push_back(target_region(c, pt));
    return out;
  }
};

SimulatedRig::SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options)
    : SimulatedRig(std::move(rig), std::move(scene), seed, options, StaticCache{}) {}

SimulatedRig::SimulatedRig(camera::Rig rig, Scene scene, std::uint64_t seed, RenderOptions options,
                           const StaticCache& cache) {
  validate(scene);
  impl_ = std::make_unique<Impl>(std::move(rig), std::move(scene), seed, options);
  Impl& m = *impl_;
  const std::array<std::string, kSlotCount> names = {m.rig.visible.left, m.rig.visible.right,
                                                     m.rig.infrared.left, m.rig.infrared.right};
  for (const std::string& name : names) {
    if (!m.rig.has_camera(name))
      throw std::invalid_argument("simulated rig: the rig has no camera '" + name + "'");
    if (!m.rig.camera(name).model)
      throw std::invalid_argument("simulated rig: camera '" + name + "' has no model");
  }
  for (int i = 2; i < 4; ++i) {
    const int bits = m.rig.camera(names[static_cast<std::size_t>(i)]).bit_depth;
    if (bits < 1 || bits > 16)
      throw std::invalid_argument("simulated rig: infrared bit_depth must be 1..16");
  }
  m.world = std::make_unique<detail::World>(m.scene);
  m.static_targets = m.world->place(false, 0.0);
  for (const auto& t : m.world->targets()) m.hull_points.push_back(m.hull_of(t));
  m.T_visible_left_world = m.rig.camera(m.rig.visible.left).T_ref_cam.inverse();
  m.sky_counts = m.ir_transfer.counts(m.scene.infrared.sky_c);
  for (int v = 0; v < 256; ++v) {
    m.sigma_lut[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(
        std::min(255L, std::lround(kNoiseScale * m.exposure.sigma_dn(v))));
  }
  m.ir_sigma16 = static_cast<int>(
      std::lround(kNoiseScale * m.scene.infrared.netd_k * m.scene.infrared.counts_per_k));
  // The noise plane: long enough for the longest row at any offset.
  std::size_t longest = 0;
  for (int i = 0; i < kSlotCount; ++i) {
    const cv::Size size = m.rig.camera(names[static_cast<std::size_t>(i)]).model->image_size();
    longest = std::max(longest, static_cast<std::size_t>(size.width) * (i < 2 ? 3 : 1));
  }
  for (int i = 0; i < kSlotCount; ++i)
    m.set_geometry(static_cast<Slot>(i), m.rig.camera(names[static_cast<std::size_t>(i)]));
  // The file also holds what the seed and the fixed-pattern option decide.
  const std::string key = cache.key + " | seed " + std::to_string(seed) + ", fixed pattern " +
                          (options.fixed_pattern ? "on" : "off");
  if (!cache.file.empty()) {
    m.static_setup.note = read_static(cache.file, key, m.cams, kNoiseOffsets + longest,
                                      m.noise_plane, m.static_mapping);
    m.static_setup.loaded = m.static_setup.note.empty();
  }
  if (m.static_setup.loaded) return;
  // Layers a rejected file got as far as pointing into its mapping: released before it goes
  // (create() would keep a view of the same size and type).
  for (CameraCache& c : m.cams) {
    for (cv::Mat* layer : cached_layers(c)) layer->release();
  }
  m.static_mapping.reset();
  m.noise_plane.resize(kNoiseOffsets + longest);
  NormalStream normal(mix_seed(seed, 0xA0, 0));
  for (std::int8_t& v : m.noise_plane) {
    v = static_cast<std::int8_t>(std::clamp(std::lround(kNoiseScale * normal.next()), -127L, 127L));
  }
  for (int i = 0; i < kSlotCount; ++i) m.build_camera(static_cast<Slot>(i));
  if (!cache.file.empty()) {
    const std::string written = write_static(cache.file, key, m.cams, m.noise_plane);
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
    const CameraCache& c = impl_->cams[static_cast<std::size_t>(i)];
    out.images[static_cast<std::size_t>(i)].create(c.size, c.visible ? CV_8UC3 : CV_16UC1);
  }
  return out;
}

void SimulatedRig::render(std::int64_t frame_index, FrameSet& out) const {
  const Impl& m = *impl_;
  for (int i = 0; i < kSlotCount; ++i) {
    const CameraCache& c = m.cams[static_cast<std::size_t>(i)];
    const cv::Mat& img = out.images[static_cast<std::size_t>(i)];
    const int type = c.visible ? CV_8UC3 : CV_16UC1;
    if (img.size() != c.size || img.type() != type || !img.isContinuous()) {
      throw std::invalid_argument(
          std::string("simulated rig: buffer ") + to_string(static_cast<Slot>(i)) +
          " must be a continuous " + std::to_string(c.size.width) + "x" +
          std::to_string(c.size.height) + (c.visible ? " CV_8UC3" : " CV_16UC1") + " image");
    }
  }
  const double t_s = static_cast<double>(frame_index) / m.scene.frame_rate_hz;
  const std::vector<PlacedTarget> moving = m.world->place(true, t_s);
  for (int i = 0; i < kSlotCount; ++i) {
    const CameraCache& c = m.cams[static_cast<std::size_t>(i)];
    cv::Mat& img = out.images[static_cast<std::size_t>(i)];
    const std::uint64_t key = m.noise_key(frame_index, static_cast<Slot>(i));
    const cv::Rect whole(cv::Point(0, 0), c.size);
    m.add_noise(c, c.static_clean, c.visible ? &c.static_sigma : nullptr, whole, key, img);
    const std::vector<cv::Rect> rects = m.regions(c, moving);
    std::vector<PlacedTarget> local;
    std::vector<cv::Rect> local_rects;
    for (const cv::Rect& r : rects) {
      if (r.area() == 0) continue;
      // Only the moving targets whose own region reaches this one can cover its pixels.
      const int rb = m.blur_radius(c);
      const cv::Rect reach(r.x - rb, r.y - rb, r.width + 2 * rb, r.height + 2 * rb);
      local.clear();
      local_rects.clear();
      for (std::size_t k = 0; k < moving.size(); ++k) {
        if ((rects[k] & reach).area() == 0) continue;
        local.push_back(moving[k]);
        local_rects.push_back(rects[k]);
      }
      m.render_region(c, r, local, local_rects, key, img);
    }
  }
}

std::int64_t SimulatedRig::dynamic_pixel_count(std::int64_t frame_index) const {
  const Impl& m = *impl_;
  const std::vector<PlacedTarget> moving =
      m.world->place(true, static_cast<double>(frame_index) / m.scene.frame_rate_hz);
  std::int64_t total = 0;
  for (const CameraCache& c : m.cams) {
    for (const cv::Rect& r : m.regions(c, moving)) total += r.area();
  }
  return total;
}

std::vector<TargetTruth> SimulatedRig::truth(std::int64_t frame_index) const {
  const Impl& m = *impl_;
  const double t_s = static_cast<double>(frame_index) / m.scene.frame_rate_hz;
  std::vector<TargetTruth> out;
  for (const detail::CompiledTarget& t : m.world->targets()) {
    TargetTruth truth;
    truth.id = t.spec.id;
    truth.cls = t.spec.cls;
    const Eigen::Vector3d foot = foot_position(m.scene, t.spec, t_s);
    truth.position_m = m.T_visible_left_world * centre_position(m.scene, t.spec, t_s);
    truth.distance_m = truth.position_m.norm();
    for (int i = 0; i < kSlotCount; ++i) {
      const CameraCache& c = m.cams[static_cast<std::size_t>(i)];
      const auto extent = m.projected_extent(c, t.silhouette_points, t, foot);
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
  RayTruth out;
  const double norm = direction.norm();
  if (!(norm > 0.0) || !origin_m.allFinite() || !direction.allFinite()) return out;
  const Eigen::Vector3d d = direction / norm;
  Hit hit;
  m.world->trace_background(origin_m, d, hit);
  detail::World::trace_targets(m.static_targets, origin_m, d, hit);
  detail::World::trace_targets(
      m.world->place(true, static_cast<double>(frame_index) / m.scene.frame_rate_hz), origin_m, d,
      hit);
  if (hit.id == detail::kSkyId || !std::isfinite(hit.t)) return out;
  out.hit = true;
  out.distance_m = hit.t;
  if (hit.id >= detail::kFirstTargetId && hit.id != detail::kNoRayId) {
    const std::size_t i = hit.id - detail::kFirstTargetId;
    if (i < m.world->targets().size()) out.target_id = m.world->targets()[i].spec.id;
  }
  return out;
}

}  // namespace thermovis::sim
