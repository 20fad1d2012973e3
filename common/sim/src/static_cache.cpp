#include "static_cache.hpp"

#include <cstring>
#include <fstream>
#include <system_error>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

namespace thermovis::sim::detail {
namespace {

std::vector<int> cached_types(const CameraLayers& c) {
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

}  // namespace

std::vector<cv::Mat*> cached_layers(CameraLayers& c) {
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

std::string write_static_cache(const std::filesystem::path& file, const std::string& key,
                               std::array<CameraLayers, kSlotCount>& cams,
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
    for (CameraLayers& c : cams) {
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
    for (CameraLayers& c : cams) {
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

std::string read_static_cache(const std::filesystem::path& file, const std::string& key,
                              std::array<CameraLayers, kSlotCount>& cams, std::size_t plane_size,
                              std::vector<std::int8_t>& noise_plane,
                              std::shared_ptr<void>& mapping) {
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
    CameraLayers& c = cams[static_cast<std::size_t>(i)];
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

}  // namespace thermovis::sim::detail
