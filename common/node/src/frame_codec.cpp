#include "thermovis/node/frame_codec.hpp"

#include <array>
#include <cmath>
#include <string>
#include <type_traits>

namespace thermovis::node {
namespace {

// frames.idl writes the frames' array bounds as literals beside the constants they stand for
// (GRID_IMAGE_BYTES...): a constant changed alone would leave the arrays their old size.
static_assert(std::tuple_size_v<std::decay_t<decltype(VisibleStereoFrame{}.left())>> ==
              VISIBLE_IMAGE_BYTES);
static_assert(std::tuple_size_v<std::decay_t<decltype(InfraredStereoFrame{}.left())>> ==
              INFRARED_IMAGE_PIXELS);
static_assert(std::tuple_size_v<std::decay_t<decltype(GridStereoFrame{}.left())>> ==
              GRID_IMAGE_BYTES);

std::string size_text(std::uint32_t width, std::uint32_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// Checks the header of a frame against its array capacity; returns the Mat type.
// Received frames also have their stamps checked; frames being filled (prepare()) do not: a
// loaned sample's stamps are whatever its memory held until the writer sets them.
enum class Stamps { check, ignore };

template <class Frame>
int checked_type(const char* what, const Frame& f, std::size_t capacity_bytes, PixelFormat expected,
                 Stamps stamps) {
  const std::string frame = std::string(what) + " frame " + std::to_string(f.seq());
  if (stamps == Stamps::check) check_stamps(f.stamps(), f.capture_time_ns(), frame);
  const PixelFormat format = f.pixel_format();
  if (expected != 0 && format != expected) {
    throw FrameError(frame + ": pixel format " + std::to_string(format) + ", expected " +
                     std::to_string(expected));
  }
  int type = 0;
  try {
    type = cv_type_of(format);
  } catch (const FrameError& e) {
    throw FrameError(frame + ": " + e.what());
  }
  const std::uint32_t width = f.width(), height = f.height();
  if (width == 0 || height == 0)
    throw FrameError(frame + ": empty image " + size_text(width, height));
  const std::size_t row_bytes = std::size_t{width} * CV_ELEM_SIZE(type);
  if (row_bytes * height > capacity_bytes) {
    throw FrameError(frame + ": " + size_text(width, height) + " image does not fit the " +
                     std::to_string(capacity_bytes) + "-byte array of the type");
  }
  // Rows are packed; a writer that says otherwise lays its pixels out in a way this reader
  // would misread.
  if (f.step() != row_bytes) {
    throw FrameError(frame + ": step " + std::to_string(f.step()) +
                     " bytes, the packed rows of a " + size_text(width, height) + " image are " +
                     std::to_string(row_bytes));
  }
  return type;
}

// Bytes of a packed row of the frame's header (0 for an unknown pixel format, which view()
// then names).
template <class Frame>
std::size_t packed_step(const Frame& f) {
  switch (f.pixel_format()) {
    case PIXEL_FORMAT_BGR8:
      return std::size_t{f.width()} * 3;
    case PIXEL_FORMAT_MONO8:
      return f.width();
    case PIXEL_FORMAT_MONO16:
      return std::size_t{f.width()} * 2;
    default:
      return 0;
  }
}

// The frames' pixel formats and the OpenCV type of each, for both directions.
struct PixelFormatType {
  PixelFormat format;
  int cv_type;
};
constexpr PixelFormatType kPixelFormatTypes[] = {
    {PIXEL_FORMAT_BGR8, CV_8UC3}, {PIXEL_FORMAT_MONO8, CV_8UC1}, {PIXEL_FORMAT_MONO16, CV_16UC1}};

template <class Array>
void* eye_data(const Array& left, const Array& right, Eye eye) {
  return const_cast<void*>(static_cast<const void*>(eye == Eye::left ? left.data() : right.data()));
}

}  // namespace

int cv_type_of(PixelFormat format) {
  for (const auto& entry : kPixelFormatTypes)
    if (entry.format == format) return entry.cv_type;
  throw FrameError("unknown pixel format " + std::to_string(format));
}

PixelFormat pixel_format_of(int cv_type) {
  for (const auto& entry : kPixelFormatTypes)
    if (entry.cv_type == cv_type) return entry.format;
  throw FrameError("no pixel format for OpenCV type " + std::to_string(cv_type));
}

namespace {

cv::Mat view_of(const VisibleStereoFrame& f, Eye eye, Stamps stamps) {
  const int type = checked_type("visible", f, f.left().size(), PIXEL_FORMAT_BGR8, stamps);
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

cv::Mat view_of(const InfraredStereoFrame& f, Eye eye, Stamps stamps) {
  const int type = checked_type("infrared", f, f.left().size() * sizeof(std::uint16_t),
                                PIXEL_FORMAT_MONO16, stamps);
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

cv::Mat view_of(const GridStereoFrame& f, Eye eye, Stamps stamps) {
  const int type = checked_type("grid", f, f.left().size(), 0, stamps);
  if (stamps == Stamps::check) {
    const std::string frame = "grid frame " + std::to_string(f.seq());
    if (f.eyes() != EYES_BOTH && f.eyes() != EYES_LEFT)
      throw FrameError(frame + ": unknown eye set " + std::to_string(f.eyes()));
    // The right eye's bytes of a left-only frame were never written.
    if (eye == Eye::right && f.eyes() == EYES_LEFT)
      throw FrameError(frame + ": the right eye is not sent (left eye only)");
  }
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

}  // namespace

cv::Mat view(const VisibleStereoFrame& f, Eye eye) { return view_of(f, eye, Stamps::check); }
cv::Mat view(const InfraredStereoFrame& f, Eye eye) { return view_of(f, eye, Stamps::check); }
cv::Mat view(const GridStereoFrame& f, Eye eye) { return view_of(f, eye, Stamps::check); }

cv::Mat prepare(VisibleStereoFrame& f, Eye eye, cv::Size size) {
  f.pixel_format(PIXEL_FORMAT_BGR8);
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view_of(f, eye, Stamps::ignore);
}

cv::Mat prepare(InfraredStereoFrame& f, Eye eye, cv::Size size) {
  f.pixel_format(PIXEL_FORMAT_MONO16);
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view_of(f, eye, Stamps::ignore);
}

cv::Mat prepare(GridStereoFrame& f, Eye eye, cv::Size size, int cv_type) {
  f.pixel_format(pixel_format_of(cv_type));
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view_of(f, eye, Stamps::ignore);
}

cv::Mat view(const GridStereoFrame& f, Eye eye, cv::Size grid) {
  // The frame's own header first (an impossible size is named as such), then the grid.
  cv::Mat image = view(f, eye);
  if (image.cols != grid.width || image.rows != grid.height) {
    throw FrameError(
        "grid frame " + std::to_string(f.seq()) + ": " + size_text(f.width(), f.height()) +
        " image, this service's grid is " +
        size_text(static_cast<std::uint32_t>(grid.width), static_cast<std::uint32_t>(grid.height)) +
        " (the geometry on thermovis/geometry)");
  }
  return image;
}

Band to_message(pipeline::Band band) {
  switch (band) {
    case pipeline::Band::visible:
      return BAND_VISIBLE;
    case pipeline::Band::infrared:
      return BAND_INFRARED;
    case pipeline::Band::fused:
      return BAND_FUSED;
  }
  return BAND_UNKNOWN;
}

pipeline::Band band_of(Band band) {
  switch (band) {
    case BAND_UNKNOWN:
    case BAND_VISIBLE:
      return pipeline::Band::visible;
    case BAND_INFRARED:
      return pipeline::Band::infrared;
    case BAND_FUSED:
      return pipeline::Band::fused;
    default:
      throw FrameError("unknown band " + std::to_string(band));
  }
}

cv::Mat view(const GridStereoFrame& f, Eye eye, cv::Size grid, std::uint32_t geometry_id) {
  if (f.geometry_id() != 0 && f.geometry_id() != geometry_id) {
    throw FrameError("grid frame " + std::to_string(f.seq()) + " was made on geometry " +
                     std::to_string(f.geometry_id()) + ", this service holds geometry " +
                     std::to_string(geometry_id) + " (thermovis/geometry)");
  }
  return view(f, eye, grid);
}

void check_stamps(const PipelineStamps& stamps, std::int64_t capture_ns, const std::string& what) {
  Stage previous_stage = STAGE_NONE;
  std::int64_t previous_end_ns = capture_ns;
  bool ended = false;
  for (std::size_t i = 0; i < stamps.stamps().size(); ++i) {
    const StageStamp& stamp = stamps.stamps()[i];
    const std::string entry = what + ": stamp " + std::to_string(i);
    if (stamp.stage() == STAGE_NONE) {
      ended = true;
      continue;
    }
    if (ended) throw FrameError(entry + " follows an unused entry");
    if (stamp.stage() > STAGE_OBSTACLES)
      throw FrameError(entry + ": unknown stage " + std::to_string(stamp.stage()));
    if (stamp.stage() <= previous_stage) {
      throw FrameError(entry + ": stage " + std::to_string(stamp.stage()) + " after stage " +
                       std::to_string(previous_stage) + " (stamps out of order)");
    }
    // The difference of two arbitrary stamps may not fit an int64: taken as unsigned, which is
    // exact when end_ns < previous_end_ns.
    const std::uint64_t early_ns = stamp.end_ns() < previous_end_ns
                                       ? static_cast<std::uint64_t>(previous_end_ns) -
                                             static_cast<std::uint64_t>(stamp.end_ns())
                                       : 0;
    if (early_ns > static_cast<std::uint64_t>(kStampSkewNs)) {
      throw FrameError(entry + ": stage " + std::to_string(stamp.stage()) + " ends " +
                       std::to_string(early_ns / 1000000) + " ms before " +
                       (previous_stage == STAGE_NONE ? std::string("the capture")
                                                     : "stage " + std::to_string(previous_stage)) +
                       " (stamps out of order)");
    }
    previous_stage = stamp.stage();
    previous_end_ns = stamp.end_ns();
  }
}

void check_timing(const FrameTiming& timing) {
  const std::string what = "timing of frame " + std::to_string(timing.frame_seq());
  check_stamps(timing.stamps(), timing.capture_time_ns(), what);
  const std::int64_t capture_ns = timing.capture_time_ns();
  const std::int64_t output_ns = timing.output_time_ns();
  if (output_ns < capture_ns) {
    // As unsigned: the difference of two arbitrary stamps may not fit an int64.
    throw FrameError(what + ": output " +
                     std::to_string((static_cast<std::uint64_t>(capture_ns) -
                                     static_cast<std::uint64_t>(output_ns)) /
                                    1000000) +
                     " ms before the capture");
  }
  const std::uint64_t latency_ns =
      static_cast<std::uint64_t>(output_ns) - static_cast<std::uint64_t>(capture_ns);
  if (latency_ns > static_cast<std::uint64_t>(kMaxFrameLatencyNs)) {
    throw FrameError(what + ": latency " + std::to_string(latency_ns / 1000000) + " ms, over the " +
                     std::to_string(kMaxFrameLatencyNs / 1000000) +
                     " ms any frame can take (wrong capture or output time)");
  }
  for (std::size_t i = 0; i < timing.stamps().stamps().size(); ++i) {
    const StageStamp& stamp = timing.stamps().stamps()[i];
    if (stamp.stage() == STAGE_NONE) break;
    const std::uint64_t late_ns =
        stamp.end_ns() > output_ns
            ? static_cast<std::uint64_t>(stamp.end_ns()) - static_cast<std::uint64_t>(output_ns)
            : 0;
    if (late_ns > static_cast<std::uint64_t>(kStampSkewNs)) {
      throw FrameError(what + ": stage " + std::to_string(stamp.stage()) + " ends " +
                       std::to_string(late_ns / 1000000) + " ms after the output");
    }
    const std::int64_t duration_ns = static_cast<std::int64_t>(stamp.duration_us()) * 1000;
    if (duration_ns > static_cast<std::int64_t>(latency_ns) + kStampSkewNs) {
      throw FrameError(what + ": stage " + std::to_string(stamp.stage()) + " took " +
                       std::to_string(duration_ns / 1000000) + " ms, longer than the frame's " +
                       std::to_string(latency_ns / 1000000) + " ms latency");
    }
  }
}

FrameOrder::Verdict FrameOrder::check(std::uint64_t seq, std::int64_t capture_ns) {
  Verdict verdict = Verdict::next;
  if (any_ && seq == last_seq_ && capture_ns == last_capture_ns_) {
    return Verdict::repeated;
  } else if (any_ && seq <= last_seq_) {
    if (capture_ns <= last_capture_ns_) return Verdict::stale;
    verdict = Verdict::restarted;
  }
  any_ = true;
  last_seq_ = seq;
  last_capture_ns_ = capture_ns;
  return verdict;
}

cv::Rect to_rect(const Box2D& box) {
  const float fields[] = {box.x(), box.y(), box.width(), box.height()};
  for (const float v : fields) {
    if (!std::isfinite(v) || std::abs(v) > 1e6f) return {};
  }
  const int x0 = static_cast<int>(std::floor(box.x()));
  const int y0 = static_cast<int>(std::floor(box.y()));
  const int x1 = static_cast<int>(std::ceil(box.x() + box.width()));
  const int y1 = static_cast<int>(std::ceil(box.y() + box.height()));
  if (x1 <= x0 || y1 <= y0) return {};
  return {x0, y0, x1 - x0, y1 - y0};
}

Box2D to_box(const cv::Rect& rect) {
  Box2D box;
  box.x(static_cast<float>(rect.x));
  box.y(static_cast<float>(rect.y));
  box.width(static_cast<float>(rect.width));
  box.height(static_cast<float>(rect.height));
  return box;
}

}  // namespace thermovis::node
