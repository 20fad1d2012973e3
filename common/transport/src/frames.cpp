#include "thermovis/transport/frames.hpp"

#include <cstring>
#include <stdexcept>

namespace thermovis::transport {
namespace {

// The bytes an eye of `frame` holds: height x step, checked against the eye's capacity.
template <class Plain>
std::size_t image_bytes(const Plain& frame) {
  const std::size_t bytes = static_cast<std::size_t>(frame.height()) * frame.step();
  const std::size_t capacity = sizeof(frame.left());
  if (bytes > capacity) {
    throw std::invalid_argument("height " + std::to_string(frame.height()) + " x step " +
                                std::to_string(frame.step()) + " = " + std::to_string(bytes) +
                                " bytes exceeds the frame's " + std::to_string(capacity));
  }
  return bytes;
}

void copy_eye(const void* from, std::size_t bytes, std::vector<std::uint8_t>& to) {
  to.resize(bytes);
  if (bytes > 0) std::memcpy(to.data(), from, bytes);
}

template <class Plain>
void pack_common(const Plain& from, PackedStereoFrame& to, bool right_eye) {
  const std::size_t bytes = image_bytes(from);
  to.seq(from.seq());
  to.capture_time_ns(from.capture_time_ns());
  to.stamps(from.stamps());
  to.pixel_format(from.pixel_format());
  to.width(from.width());
  to.height(from.height());
  to.step(from.step());
  copy_eye(from.left().data(), bytes, to.left());
  copy_eye(from.right().data(), right_eye ? bytes : 0, to.right());
}

// The header and the eyes of `from` into `to`; `eyes` is the frame's EyeSet.
template <class Plain>
void unpack_common(const PackedStereoFrame& from, Plain& to, EyeSet eyes) {
  const std::size_t bytes = static_cast<std::size_t>(from.height()) * from.step();
  const std::size_t capacity = sizeof(to.left());
  if (bytes > capacity) {
    throw std::invalid_argument("height " + std::to_string(from.height()) + " x step " +
                                std::to_string(from.step()) + " = " + std::to_string(bytes) +
                                " bytes does not fit the plain frame's " +
                                std::to_string(capacity));
  }
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
  to.seq(from.seq());
  to.capture_time_ns(from.capture_time_ns());
  to.stamps(from.stamps());
  to.pixel_format(from.pixel_format());
  to.width(from.width());
  to.height(from.height());
  to.step(from.step());
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
