#include "thermovis/fpga/ring.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <opencv2/core.hpp>
#include <thread>
#include <type_traits>
#include <utility>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::fpga {

static_assert(std::atomic<std::uint64_t>::is_always_lock_free,
              "the ring needs lock-free 64-bit atomics (shared with the FPGA)");
static_assert(sizeof(std::atomic<std::uint64_t>) == 8);
static_assert(std::is_standard_layout_v<RingHeader> && std::is_standard_layout_v<RingSlotHeader>);
static_assert(sizeof(RingImageLayout) == 32);
static_assert(offsetof(RingHeader, slot_bytes) == 24);
static_assert(offsetof(RingHeader, images) == 48);
static_assert(offsetof(RingHeader, write_index) == 192);
static_assert(sizeof(RingHeader) <= kRingHeaderBytes);
static_assert(offsetof(RingSlotHeader, frame_seq) == 16);
static_assert(offsetof(RingSlotHeader, capture_time_ns) == 24);
static_assert(sizeof(RingSlotHeader) == kRingSlotHeaderBytes);

namespace {

constexpr std::uint64_t kPage = 4096;
constexpr std::uint64_t kImageAlign = 64;

constexpr util::EnumName<RingPixelFormat> kPixelFormatNames[] = {
    {RingPixelFormat::bgr8, "BGR8"}, {RingPixelFormat::mono16, "MONO16"}};

std::uint64_t round_up(std::uint64_t value, std::uint64_t step) {
  return (value + step - 1) / step * step;
}

std::string errno_text() { return std::strerror(errno); }

const char* camera_name(int camera) {
  static const char* const names[kRingCameras] = {"visible left", "visible right", "infrared left",
                                                  "infrared right"};
  return names[camera];
}

std::string size_text(cv::Size size) {
  return std::to_string(size.width) + "x" + std::to_string(size.height);
}

// "shm:name" -> POSIX shared-memory object "/name"; anything else is a file path.
bool is_shm_name(const std::string& path) { return path.rfind("shm:", 0) == 0; }
std::string shm_object(const std::string& path) {
  std::string name = path.substr(3);  // ":name"
  name[0] = '/';
  return name;
}

int open_backing(const std::string& path, int flags, mode_t mode) {
  return is_shm_name(path) ? ::shm_open(shm_object(path).c_str(), flags, mode)
                           : ::open(path.c_str(), flags | O_CLOEXEC, mode);
}

RingHeader* header_of(const RingMapping& mapping) {
  return reinterpret_cast<RingHeader*>(mapping.data());
}

RingSlotHeader* slot_header(const RingMapping& mapping, const RingHeader& header,
                            std::uint64_t slot) {
  return reinterpret_cast<RingSlotHeader*>(mapping.data() + header.header_bytes +
                                           slot * header.slot_bytes);
}

// Mat headers over the four images of a slot (no copy).
std::array<cv::Mat, kRingCameras> slot_views(const RingMapping& mapping, const RingHeader& header,
                                             std::uint64_t slot) {
  std::uint8_t* base = mapping.data() + header.header_bytes + slot * header.slot_bytes;
  std::array<cv::Mat, kRingCameras> views;
  for (int i = 0; i < kRingCameras; ++i) {
    const RingImageLayout& layout = header.images[i];
    views[static_cast<std::size_t>(i)] =
        cv::Mat(static_cast<int>(layout.height), static_cast<int>(layout.width),
                cv_type_of(static_cast<RingPixelFormat>(layout.pixel_format)),
                base + layout.offset_bytes, layout.stride_bytes);
  }
  return views;
}

void check_images(const std::array<cv::Mat, kRingCameras>& images, const RingGeometry& geometry,
                  const std::string& path) {
  for (int i = 0; i < kRingCameras; ++i) {
    const cv::Mat& image = images[static_cast<std::size_t>(i)];
    const RingImageFormat& expected = geometry.images[static_cast<std::size_t>(i)];
    if (image.size() != expected.size || image.type() != cv_type_of(expected.format)) {
      throw RingError("ring " + path + ": " + camera_name(i) + " image is " +
                      size_text(image.size()) + " type " + std::to_string(image.type()) +
                      ", the ring holds " + size_text(expected.size) + " " +
                      to_string(expected.format));
    }
  }
}

// Maps `bytes` of the ring file open on `fd` (shared, with `protection`) and closes `fd`, which
// the mapping does not need. RingError naming `path` when the mapping fails.
std::uint8_t* map_and_close(int fd, std::size_t bytes, int protection, const std::string& path) {
  void* data = ::mmap(nullptr, bytes, protection, MAP_SHARED, fd, 0);
  const std::string why = errno_text();
  ::close(fd);
  if (data == MAP_FAILED) throw RingError("cannot map ring " + path + ": " + why);
  return static_cast<std::uint8_t*>(data);
}

}  // namespace

const char* to_string(RingPixelFormat format) {
  return util::name_of(kPixelFormatNames, format, "unknown");
}

int cv_type_of(RingPixelFormat format) {
  switch (format) {
    case RingPixelFormat::bgr8:
      return CV_8UC3;
    case RingPixelFormat::mono16:
      return CV_16UC1;
  }
  throw RingError("unknown ring pixel format " +
                  std::to_string(static_cast<std::uint32_t>(format)));
}

int bytes_per_pixel(RingPixelFormat format) { return format == RingPixelFormat::bgr8 ? 3 : 2; }

RingGeometry stereo_rig_geometry(cv::Size visible_size, cv::Size infrared_size,
                                 std::uint32_t slot_count) {
  RingGeometry geometry;
  geometry.slot_count = slot_count;
  geometry.images = {RingImageFormat{visible_size, RingPixelFormat::bgr8},
                     RingImageFormat{visible_size, RingPixelFormat::bgr8},
                     RingImageFormat{infrared_size, RingPixelFormat::mono16},
                     RingImageFormat{infrared_size, RingPixelFormat::mono16}};
  return geometry;
}

// ---- RingMapping ----------------------------------------------------------------------------

RingMapping::RingMapping(RingMapping&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      device_(other.device_),
      inode_(other.inode_) {}

RingMapping& RingMapping::operator=(RingMapping&& other) noexcept {
  if (this != &other) {
    if (data_ != nullptr) ::munmap(data_, size_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    device_ = other.device_;
    inode_ = other.inode_;
  }
  return *this;
}

RingMapping::~RingMapping() {
  if (data_ != nullptr) ::munmap(data_, size_);
}

RingMapping RingMapping::create(const std::string& path, std::size_t bytes) {
  // A new file, never the old one truncated: readers still mapping an older ring at this path
  // must not lose its pages under them (SIGBUS); they see replaced() instead.
  if (is_shm_name(path))
    ::shm_unlink(shm_object(path).c_str());
  else
    ::unlink(path.c_str());
  const int fd = open_backing(path, O_RDWR | O_CREAT | O_EXCL, 0660);
  if (fd < 0) throw RingError("cannot create ring " + path + ": " + errno_text());
  if (::ftruncate(fd, static_cast<off_t>(bytes)) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    throw RingError("cannot size ring " + path + " to " + std::to_string(bytes) + " bytes: " + why);
  }
  RingMapping mapping;
  mapping.data_ = map_and_close(fd, bytes, PROT_READ | PROT_WRITE, path);
  mapping.size_ = bytes;
  return mapping;
}

RingMapping RingMapping::open_read(const std::string& path) {
  const int fd = open_backing(path, O_RDONLY, 0);
  if (fd < 0) {
    throw RingError(
        "cannot open ring " + path + ": " + errno_text() +
        (errno == ENOENT ? " (is the FPGA driver or thermovis-fpga-emu running?)" : ""));
  }
  struct stat info {};
  if (::fstat(fd, &info) != 0) {
    const std::string why = errno_text();
    ::close(fd);
    throw RingError("cannot stat ring " + path + ": " + why);
  }
  const auto bytes = static_cast<std::size_t>(info.st_size);
  if (bytes < kRingHeaderBytes) {
    ::close(fd);
    throw RingError("ring " + path + " is " + std::to_string(bytes) + " bytes, too small for the " +
                    std::to_string(kRingHeaderBytes) + "-byte ring header");
  }
  RingMapping mapping;
  mapping.data_ = map_and_close(fd, bytes, PROT_READ, path);
  mapping.size_ = bytes;
  mapping.device_ = info.st_dev;
  mapping.inode_ = info.st_ino;
  return mapping;
}

bool RingMapping::replaced(const std::string& path) const {
  const int fd = open_backing(path, O_RDONLY, 0);
  if (fd < 0) return true;
  struct stat info {};
  const bool same = ::fstat(fd, &info) == 0 && info.st_dev == device_ && info.st_ino == inode_;
  ::close(fd);
  return !same;
}

// ---- RingWriter -----------------------------------------------------------------------------

RingWriter::RingWriter(const std::string& path, const RingGeometry& geometry)
    : path_(path), geometry_(geometry) {
  if (geometry.slot_count < 2) {
    throw RingError("ring " + path + ": needs at least 2 slots, got " +
                    std::to_string(geometry.slot_count));
  }
  RingImageLayout layouts[kRingCameras];
  std::uint64_t offset = kRingSlotHeaderBytes;
  for (int i = 0; i < kRingCameras; ++i) {
    const RingImageFormat& image = geometry.images[static_cast<std::size_t>(i)];
    if (image.size.width <= 0 || image.size.height <= 0 || image.size.width > 65535 ||
        image.size.height > 65535) {
      throw RingError("ring " + path + ": " + camera_name(i) + " image size " +
                      size_text(image.size) + " is not in 1..65535 px");
    }
    cv_type_of(image.format);  // throws for an unknown format
    RingImageLayout& layout = layouts[i];
    layout.width = static_cast<std::uint32_t>(image.size.width);
    layout.height = static_cast<std::uint32_t>(image.size.height);
    layout.pixel_format = static_cast<std::uint32_t>(image.format);
    layout.stride_bytes = layout.width * static_cast<std::uint32_t>(bytes_per_pixel(image.format));
    layout.offset_bytes = offset;
    layout.size_bytes = static_cast<std::uint64_t>(layout.stride_bytes) * layout.height;
    offset = round_up(offset + layout.size_bytes, kImageAlign);
  }
  const std::uint64_t slot_bytes = round_up(offset, kPage);
  mapping_ = RingMapping::create(path, kRingHeaderBytes + geometry.slot_count * slot_bytes);

  RingHeader* header = header_of(mapping_);
  // The mapping is fresh and zero-filled: the atomics start at 0 (no capture, no slot written).
  header->version = kRingVersion;
  header->header_bytes = kRingHeaderBytes;
  header->slot_count = geometry.slot_count;
  header->camera_count = kRingCameras;
  header->slot_bytes = slot_bytes;
  for (int i = 0; i < kRingCameras; ++i) header->images[i] = layouts[i];
  std::atomic_thread_fence(std::memory_order_release);
  std::atomic_ref<std::uint64_t>(header->magic).store(kRingMagic, std::memory_order_release);
}

std::uint64_t RingWriter::written() const {
  return header_of(mapping_)->write_index.load(std::memory_order_acquire);
}

std::array<cv::Mat, kRingCameras> RingWriter::begin() {
  RingHeader& header = *header_of(mapping_);
  const std::uint64_t n = header.write_index.load(std::memory_order_relaxed);
  const std::uint64_t slot = n % header.slot_count;
  RingSlotHeader* slot_head = slot_header(mapping_, header, slot);
  slot_head->begin_seq.store(n + 1, std::memory_order_relaxed);
  // Readers that see any byte of the new images must also see begin_seq changed.
  std::atomic_thread_fence(std::memory_order_release);
  writing_ = true;
  return slot_views(mapping_, header, slot);
}

void RingWriter::commit(std::uint64_t frame_seq, std::int64_t capture_time_ns) {
  if (!writing_) throw RingError("ring " + path_ + ": commit() without begin()");
  RingHeader& header = *header_of(mapping_);
  const std::uint64_t n = header.write_index.load(std::memory_order_relaxed);
  RingSlotHeader* slot_head = slot_header(mapping_, header, n % header.slot_count);
  slot_head->frame_seq = frame_seq;
  slot_head->capture_time_ns = capture_time_ns;
  slot_head->end_seq.store(n + 1, std::memory_order_release);
  header.write_index.store(n + 1, std::memory_order_release);
  writing_ = false;
}

void RingWriter::write(const std::array<cv::Mat, kRingCameras>& images, std::uint64_t frame_seq,
                       std::int64_t capture_time_ns) {
  check_images(images, geometry_, path_);
  auto views = begin();
  for (std::size_t i = 0; i < views.size(); ++i) images[i].copyTo(views[i]);
  commit(frame_seq, capture_time_ns);
}

void RingWriter::remove() const {
  if (is_shm_name(path_))
    ::shm_unlink(shm_object(path_).c_str());
  else
    ::unlink(path_.c_str());
}

// ---- RingReader -----------------------------------------------------------------------------

RingReader::RingReader(const std::string& path, Mode mode)
    : path_(path), mode_(mode), mapping_(RingMapping::open_read(path)) {
  const RingHeader& header = *header_of(mapping_);
  // The writer stores the magic last (release); a load-only atomic_ref on the read-only mapping.
  const std::uint64_t magic =
      std::atomic_ref<std::uint64_t>(const_cast<std::uint64_t&>(header.magic))
          .load(std::memory_order_acquire);
  if (magic != kRingMagic) {
    throw RingError("ring " + path + ": bad magic 0x" +
                    cv::format("%016llx", static_cast<unsigned long long>(magic)) +
                    " (expected \"TVISRING\"): not a thermovis capture ring, or not yet "
                    "initialised by its writer");
  }
  if (header.version != kRingVersion) {
    throw RingError("ring " + path + ": version " + std::to_string(header.version) +
                    ", this reader understands version " + std::to_string(kRingVersion));
  }
  if (header.camera_count != kRingCameras || header.slot_count < 2 ||
      header.header_bytes < sizeof(RingHeader) || header.slot_bytes < kRingSlotHeaderBytes) {
    throw RingError("ring " + path + ": impossible header (cameras " +
                    std::to_string(header.camera_count) + ", slots " +
                    std::to_string(header.slot_count) + ", header " +
                    std::to_string(header.header_bytes) + " bytes, slot " +
                    std::to_string(header.slot_bytes) + " bytes)");
  }
  const std::uint64_t needed =
      header.header_bytes + static_cast<std::uint64_t>(header.slot_count) * header.slot_bytes;
  if (mapping_.size() < needed) {
    throw RingError("ring " + path + " is " + std::to_string(mapping_.size()) +
                    " bytes, its header describes " + std::to_string(needed) + " (truncated ring)");
  }
  geometry_.slot_count = header.slot_count;
  for (int i = 0; i < kRingCameras; ++i) {
    const RingImageLayout& layout = header.images[i];
    const auto format = static_cast<RingPixelFormat>(layout.pixel_format);
    if (format != RingPixelFormat::bgr8 && format != RingPixelFormat::mono16) {
      throw RingError("ring " + path + ": " + camera_name(i) + " has unknown pixel format " +
                      std::to_string(layout.pixel_format));
    }
    const std::uint64_t row = static_cast<std::uint64_t>(layout.width) *
                              static_cast<std::uint64_t>(bytes_per_pixel(format));
    if (layout.width == 0 || layout.height == 0 || layout.stride_bytes < row ||
        layout.offset_bytes < kRingSlotHeaderBytes ||
        layout.size_bytes < static_cast<std::uint64_t>(layout.stride_bytes) * layout.height ||
        layout.offset_bytes + layout.size_bytes > header.slot_bytes) {
      throw RingError("ring " + path + ": " + camera_name(i) + " image layout (" +
                      std::to_string(layout.width) + "x" + std::to_string(layout.height) +
                      ", stride " + std::to_string(layout.stride_bytes) + ", offset " +
                      std::to_string(layout.offset_bytes) + ") does not fit its " +
                      std::to_string(header.slot_bytes) + "-byte slot");
    }
    geometry_.images[static_cast<std::size_t>(i)] = {
        cv::Size(static_cast<int>(layout.width), static_cast<int>(layout.height)), format};
  }
  next_ = header.write_index.load(std::memory_order_acquire);
}

void RingReader::require_images(const RingGeometry& expected) const {
  for (int i = 0; i < kRingCameras; ++i) {
    const RingImageFormat& have = geometry_.images[static_cast<std::size_t>(i)];
    const RingImageFormat& want = expected.images[static_cast<std::size_t>(i)];
    if (have.size != want.size || have.format != want.format) {
      throw RingError("ring " + path_ + ": " + camera_name(i) + " slots hold " +
                      size_text(have.size) + " " + to_string(have.format) +
                      ", the rig's camera is " + size_text(want.size) + " " +
                      to_string(want.format));
    }
  }
}

bool RingReader::read(RingCapture& out, std::chrono::nanoseconds timeout) {
  for (std::size_t i = 0; i < out.images.size(); ++i) {
    out.images[i].create(geometry_.images[i].size, cv_type_of(geometry_.images[i].format));
  }
  const bool got = read_into(out.images, out.frame_seq, out.capture_time_ns, timeout);
  if (got) out.ring_index = next_ - 1;
  return got;
}

bool RingReader::read_into(std::array<cv::Mat, kRingCameras>& images, std::uint64_t& frame_seq,
                           std::int64_t& capture_time_ns, std::chrono::nanoseconds timeout) {
  check_images(images, geometry_, path_);
  const RingHeader& header = *header_of(mapping_);
  const std::uint64_t slots = header.slot_count;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const std::uint64_t written = header.write_index.load(std::memory_order_acquire);
    if (written <= next_) {
      // Nothing new. Polling at 100 us costs nothing measurable and keeps the wake-up latency
      // far below a frame period (20 ms); an FPGA driver could offer an eventfd instead.
      if (std::chrono::steady_clock::now() >= deadline) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(100));
      continue;
    }
    // Captures [written - slots + 1, written - 1] are complete and not being overwritten (the
    // writer may be filling slot `written % slots`, which held written - slots).
    std::uint64_t n = next_;
    const std::uint64_t oldest_safe = written >= slots ? written - slots + 1 : 0;
    if (mode_ == Mode::latest) n = written - 1;
    if (n < oldest_safe) n = oldest_safe;
    stats_.skipped += n - next_;
    next_ = n;

    const std::uint64_t slot = n % slots;
    const RingSlotHeader* slot_head = slot_header(mapping_, header, slot);
    if (slot_head->end_seq.load(std::memory_order_acquire) != n + 1) {
      // Reused between reading write_index and here: start again from the newest.
      continue;
    }
    const auto views = slot_views(mapping_, header, slot);
    for (std::size_t i = 0; i < views.size(); ++i) views[i].copyTo(images[i]);
    const std::uint64_t seq = slot_head->frame_seq;
    const std::int64_t stamp = slot_head->capture_time_ns;
    if (after_copy_hook_) after_copy_hook_();
    // The copy must be complete before begin_seq is checked again.
    std::atomic_thread_fence(std::memory_order_acquire);
    if (slot_head->begin_seq.load(std::memory_order_relaxed) != n + 1) {
      ++stats_.torn;
      ++stats_.skipped;
      ++next_;
      continue;
    }
    frame_seq = seq;
    capture_time_ns = stamp;
    ++stats_.delivered;
    ++next_;
    return true;
  }
}

}  // namespace thermovis::fpga
