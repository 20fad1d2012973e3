#include "thermovis/transport/frames.hpp"

#include <cstring>
#include <stdexcept>

namespace thermovis::transport {
namespace {

// height x step, checked against an eye's capacity (`what` names the side that is short).
std::size_t checked_bytes(std::uint32_t height, std::uint32_t step, std::size_t capacity,
                          const char* what) {
  const std::size_t bytes = static_cast<std::size_t>(height) * step;
  if (bytes > capacity) {
    throw std::invalid_argument("height " + std::to_string(height) + " x step " +
                                std::to_string(step) + " = " + std::to_string(bytes) +
                                " bytes does not fit " + what + " " + std::to_string(capacity));
  }
  return bytes;
}

// The header fields every frame type has.
template <class From, class To>
void copy_header(const From& from, To& to) {
  to.seq(from.seq());
  to.capture_time_ns(from.capture_time_ns());
  to.stamps(from.stamps());
  to.pixel_format(from.pixel_format());
  to.width(from.width());
  to.height(from.height());
  to.step(from.step());
}

void copy_eye(const void* from, std::size_t bytes, std::vector<std::uint8_t>& to) {
  to.resize(bytes);
  if (bytes > 0) std::memcpy(to.data(), from, bytes);
}

template <class Plain>
void pack_common(const Plain& from, PackedStereoFrame& to, bool right_eye) {
  const std::size_t bytes =
      checked_bytes(from.height(), from.step(), sizeof(from.left()), "the frame's eye of");
  copy_header(from, to);
  copy_eye(from.left().data(), bytes, to.left());
  copy_eye(from.right().data(), right_eye ? bytes : 0, to.right());
}

// The header and the eyes of `from` into `to`; `eyes` is the frame's EyeSet.
template <class Plain>
void unpack_common(const PackedStereoFrame& from, Plain& to, EyeSet eyes) {
  const std::size_t bytes =
      checked_bytes(from.height(), from.step(), sizeof(to.left()), "the plain frame's eye of");
  if (from.left().size() != bytes) {
    throw std::invalid_argument("left eye holds " + std::to_string(from.left().size()) +
                                " bytes, height x step is " + std::to_string(bytes));
  }
  const std::size_t right = eyes == EYES_LEFT ? 0 : bytes;
  if (from.right().size() != right) {
    throw std::invalid_argument("right eye holds " + std::to_string(from.right().size()) +
                                " bytes, " + std::to_string(right) + " expected" +
                                (eyes == EYES_LEFT ? " (EYES_LEFT)" : ""));
  }
  copy_header(from, to);
  if (bytes > 0) std::memcpy(to.left().data(), from.left().data(), bytes);
  if (right > 0) std::memcpy(to.right().data(), from.right().data(), right);
}

// A raw frame of the bridge has both eyes and no grid.
void check_raw(const PackedStereoFrame& from) {
  if (from.eyes() != EYES_BOTH) {
    throw std::invalid_argument("eyes " + std::to_string(from.eyes()) +
                                ": a raw frame carries both eyes");
  }
}

}  // namespace

std::string packed_topic(const std::string& frame_topic) { return frame_topic + "/packed"; }

void pack(const VisibleStereoFrame& from, PackedStereoFrame& to) {
  pack_common(from, to, true);
  to.eyes(EYES_BOTH);
  to.geometry_id(0);
}

void pack(const InfraredStereoFrame& from, PackedStereoFrame& to) {
  pack_common(from, to, true);
  to.eyes(EYES_BOTH);
  to.geometry_id(0);
}

void pack(const GridStereoFrame& from, PackedStereoFrame& to) {
  pack_common(from, to, from.eyes() != EYES_LEFT);
  to.eyes(from.eyes());
  to.geometry_id(from.geometry_id());
}

void unpack(const PackedStereoFrame& from, VisibleStereoFrame& to) {
  check_raw(from);
  unpack_common(from, to, EYES_BOTH);
}

void unpack(const PackedStereoFrame& from, InfraredStereoFrame& to) {
  check_raw(from);
  unpack_common(from, to, EYES_BOTH);
}

void unpack(const PackedStereoFrame& from, GridStereoFrame& to) {
  unpack_common(from, to, from.eyes());
  to.eyes(from.eyes());
  to.geometry_id(from.geometry_id());
}

}  // namespace thermovis::transport
