#pragma once
// The capture ring: how raw captures of the four cameras travel from the FPGA (or its software
// emulation, thermovis-fpga-emu) to the bridge through one memory-mapped buffer, without locks.
//
// Backing: a file of header_bytes + slot_count * slot_bytes bytes, mapped shared by the writer
// (the FPGA's DMA engine, or the emulator) and one or more readers (thermovis-bridge). A path
// under /dev/shm is POSIX shared memory (what shm_open("/name") opens); "shm:name" is accepted as
// shorthand for shm_open("/name"); any other path is an ordinary file (mmap'ed, e.g. a device
// node's exported buffer or a test file).
//
// What a real FPGA (or its driver) must write, all integers little-endian:
//
// Ring header, at offset 0, kRingHeaderBytes (4096) bytes:
//   off size field
//     0    8 magic          kRingMagic, the ASCII bytes "TVISRING"
//     8    4 version        kRingVersion
//    12    4 header_bytes   4096: where slot 0 starts
//    16    4 slot_count     number of slots (>= 2)
//    20    4 camera_count   4
//    24    8 slot_bytes     size of one slot, a multiple of 4096
//    32   16 reserved       0
//    48  128 images[4]      one RingImageLayout per camera, in the order visible left, visible
//                           right, infrared left, infrared right (sim::Slot's order):
//                             +0 u32 width (px)   +4 u32 height (px)
//                             +8 u32 pixel_format (1 = BGR8: 3 bytes per pixel, B G R;
//                                                  2 = MONO16: one uint16 per pixel, raw counts
//                                                  in the low bits)
//                            +12 u32 stride_bytes (bytes per row, >= width * bytes per pixel)
//                            +16 u64 offset_bytes (from the start of the slot, multiple of 64)
//                            +24 u64 size_bytes   (stride_bytes * height)
//   192    8 write_index    number of captures committed so far (a 64-bit atomic): capture n
//                           (0, 1, 2, ...) lives in slot n % slot_count
// The layout fields are written once, before the magic; the magic last, so a reader that maps a
// ring being created sees no valid magic rather than a half-written layout.
//
// Slot s starts at header_bytes + s * slot_bytes. Its first 64 bytes are a RingSlotHeader:
//   off size field
//     0    8 begin_seq        n + 1, stored BEFORE any byte of capture n's images is written
//     8    8 end_seq          n + 1, stored AFTER all of capture n's images are written
//    16    8 frame_seq        the FPGA's own frame counter of the capture
//    24    8 capture_time_ns  start of exposure, ns since the Unix epoch (the pipeline's clock,
//                             transport/clock.hpp; an FPGA stamps from a PTP-disciplined timer or
//                             its driver converts)
//    32   32 reserved
// followed by the four images at their offset_bytes.
//
// Writing capture n (the protocol a DMA engine must follow; stores become visible in order):
//   1. slot = n % slot_count; store begin_seq = n + 1;
//   2. write the four images, frame_seq and capture_time_ns;
//   3. store end_seq = n + 1;  4. store write_index = n + 1.
// Reading (seqlock): a reader wanting capture n waits for write_index > n, checks end_seq == n + 1
// (else the slot was already reused: overrun), copies the slot, then checks begin_seq == n + 1
// (else the writer started overwriting the slot while it was copied: a torn copy, discarded).
// A reader never writes to the ring, so any number of readers may share it.
#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <stdexcept>
#include <string>
#include <utility>

namespace thermovis::fpga {

inline constexpr std::uint64_t kRingMagic = 0x474E495253495654ULL;  // "TVISRING" little-endian
inline constexpr std::uint32_t kRingVersion = 1;
inline constexpr std::uint32_t kRingHeaderBytes = 4096;
inline constexpr std::uint32_t kRingSlotHeaderBytes = 64;
inline constexpr int kRingCameras = 4;  // visible left, visible right, infrared left, right

enum class RingPixelFormat : std::uint32_t { bgr8 = 1, mono16 = 2 };
const char* to_string(RingPixelFormat format);
int cv_type_of(RingPixelFormat format);  // CV_8UC3, CV_16UC1
int bytes_per_pixel(RingPixelFormat format);

// Bad rings and bad use: a missing ring, a wrong magic or version, sizes that do not fit.
class RingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The shared-memory layout (see the header comment for offsets). Plain fixed-width fields and
// lock-free 64-bit atomics only, so both sides agree on every byte.
struct RingImageLayout {
  std::uint32_t width;
  std::uint32_t height;
  std::uint32_t pixel_format;
  std::uint32_t stride_bytes;
  std::uint64_t offset_bytes;
  std::uint64_t size_bytes;
};

struct RingHeader {
  std::uint64_t magic;
  std::uint32_t version;
  std::uint32_t header_bytes;
  std::uint32_t slot_count;
  std::uint32_t camera_count;
  std::uint64_t slot_bytes;
  std::uint64_t reserved[2];
  RingImageLayout images[kRingCameras];
  std::uint64_t padding[2];
  std::atomic<std::uint64_t> write_index;
};

struct RingSlotHeader {
  std::atomic<std::uint64_t> begin_seq;
  std::atomic<std::uint64_t> end_seq;
  std::uint64_t frame_seq;
  std::int64_t capture_time_ns;
  std::uint64_t reserved[4];
};

// The images of one camera as the ring describes them.
struct RingImageFormat {
  cv::Size size;
  RingPixelFormat format = RingPixelFormat::bgr8;
};

// What a writer creates: slot count and the four cameras' images (sim::Slot order).
struct RingGeometry {
  std::uint32_t slot_count = 4;
  std::array<RingImageFormat, kRingCameras> images;
};

// The geometry of the paper's kind of rig: BGR8 visible pair, MONO16 infrared pair.
RingGeometry stereo_rig_geometry(cv::Size visible_size, cv::Size infrared_size,
                                 std::uint32_t slot_count = 4);

// One capture copied out of (or to be written into) the ring.
struct RingCapture {
  std::array<cv::Mat, kRingCameras> images;  // CV_8UC3 visible, CV_16UC1 infrared
  std::uint64_t frame_seq = 0;
  std::int64_t capture_time_ns = 0;
  std::uint64_t ring_index = 0;  // n: the capture's position in the ring's stream
};

// A shared mapping of a ring file (internal to writer and reader; movable, unmaps on destruction).
class RingMapping {
 public:
  RingMapping() = default;
  RingMapping(const RingMapping&) = delete;
  RingMapping& operator=(const RingMapping&) = delete;
  RingMapping(RingMapping&& other) noexcept;
  RingMapping& operator=(RingMapping&& other) noexcept;
  ~RingMapping();

  // Creates (or truncates) the file and maps it read-write.
  static RingMapping create(const std::string& path, std::size_t bytes);
  // Maps an existing ring read-only. RingError naming the path when it is missing, too small
  // for a header, or not readable.
  static RingMapping open_read(const std::string& path);

  std::uint8_t* data() const { return data_; }
  std::size_t size() const { return size_; }
  // True when `path` now names a different file than the one mapped (its writer re-created the
  // ring) or nothing at all.
  bool replaced(const std::string& path) const;

 private:
  std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
  std::uint64_t device_ = 0;
  std::uint64_t inode_ = 0;
};

// The FPGA side: creates the ring and commits captures into it, one writer per ring.
class RingWriter {
 public:
  // Creates (or replaces) the ring at `path` with `geometry`. RingError on a bad geometry
  // (fewer than 2 slots, empty images, images wider than the format allows) or an unwritable path.
  RingWriter(const std::string& path, const RingGeometry& geometry);
  // Removes nothing: the ring stays for readers; remove() deletes the backing file.
  ~RingWriter() = default;
  RingWriter(RingWriter&&) noexcept = default;
  RingWriter& operator=(RingWriter&&) noexcept = default;

  // Two-phase write, so a producer can render straight into shared memory (what DMA does):
  // begin() marks the next slot as being written (begin_seq) and returns views of its four
  // images; commit() stamps it and publishes it (end_seq, write_index). Calling begin() twice
  // without commit() reuses the same slot.
  std::array<cv::Mat, kRingCameras> begin();
  void commit(std::uint64_t frame_seq, std::int64_t capture_time_ns);
  // begin() + copy of `images` (sizes and types must match the geometry; RingError naming the
  // camera otherwise) + commit().
  void write(const std::array<cv::Mat, kRingCameras>& images, std::uint64_t frame_seq,
             std::int64_t capture_time_ns);

  const RingGeometry& geometry() const { return geometry_; }
  std::uint64_t written() const;  // captures committed so far
  const std::string& path() const { return path_; }
  // Deletes the backing file (shm_unlink for shared memory); the mapping stays valid.
  void remove() const;

 private:
  std::string path_;
  RingGeometry geometry_;
  RingMapping mapping_;
  bool writing_ = false;
};

struct RingReaderStats {
  std::uint64_t delivered = 0;  // captures copied out
  std::uint64_t skipped = 0;    // captures committed to the ring but never delivered
  std::uint64_t torn = 0;       // copies discarded because the writer overwrote the slot meanwhile
};

// The bridge side: opens an existing ring read-only and copies captures out of it.
class RingReader {
 public:
  // What to deliver when several captures are waiting.
  enum class Mode {
    next,    // the oldest not yet delivered (skips only what the writer already overwrote)
    latest,  // the newest committed (skips older waiting ones: lowest latency for a live feed)
  };
  // RingError naming the path for a missing file, a bad magic, an unknown version, a layout
  // that does not fit the file, or an unknown pixel format. Starts at the newest committed
  // capture (what was written before the reader came is not delivered nor counted).
  explicit RingReader(const std::string& path, Mode mode = Mode::next);

  const RingGeometry& geometry() const { return geometry_; }
  // RingError naming what differs unless the ring's images are exactly `expected`'s (slot
  // count aside).
  void require_images(const RingGeometry& expected) const;

  // Waits up to `timeout` for a capture not yet delivered and copies it into `out` (images
  // allocated when their size or type differ). False on timeout. Overrun captures and torn
  // copies are counted in stats() and skipped.
  bool read(RingCapture& out, std::chrono::nanoseconds timeout);
  // Same, straight into caller-provided images (sizes and types must match; RingError otherwise).
  bool read_into(std::array<cv::Mat, kRingCameras>& images, std::uint64_t& frame_seq,
                 std::int64_t& capture_time_ns, std::chrono::nanoseconds timeout);

  RingReaderStats stats() const { return stats_; }
  const std::string& path() const { return path_; }
  // True when the ring's writer has re-created the ring at this path (a reader of the old one
  // would wait forever): open a new reader.
  bool replaced() const { return mapping_.replaced(path_); }

  // Test seam: runs between a slot's copy and its begin_seq check, the window in which a writer
  // that laps the reader tears the copy (tests use it to lap the reader deterministically).
  void set_after_copy_hook(std::function<void()> hook) { after_copy_hook_ = std::move(hook); }

 private:
  std::string path_;
  Mode mode_;
  RingGeometry geometry_;
  RingMapping mapping_;
  std::uint64_t next_ = 0;  // ring index of the next capture to deliver
  RingReaderStats stats_;
  std::function<void()> after_copy_hook_;
};

}  // namespace thermovis::fpga
