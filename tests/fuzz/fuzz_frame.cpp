// libFuzzer target: frame decoding (node/frame_codec), i.e. the header fields of a frame as they
// arrive from DDS. Data-sharing hands a reader the writer's memory itself, so every field can hold
// anything: the input sets seq, pixel format, width, height, step, capture time and stage stamps
// of each frame type (and the grid a reading service expects, and a detection box). Documented
// error: node::FrameError. A view that is returned must lie inside its eye's array: its first and
// last pixel are read (the frames are on the heap, so AddressSanitizer sees a read past the right
// eye) and its extent is checked against the array (a read past the left eye would land in the
// right one).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <typeinfo>

#include "fuzz_support.hpp"
#include "thermovis/node/frame_codec.hpp"

namespace {

namespace tf = thermovis::fuzz;
namespace tn = thermovis::node;

// Reads fields from the input in order; zeros once it runs out.
class Fields {
 public:
  Fields(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <class T>
  T next() {
    T value{};
    const std::size_t n = std::min(sizeof(T), size_ - used_);
    std::memcpy(&value, data_ + used_, n);
    used_ += n;
    return value;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t used_ = 0;
};

// Grid frames also say which eyes they carry.
inline void set_eyes(thermovis::GridStereoFrame& frame, Fields& in) {
  frame.eyes(in.next<std::uint32_t>());
}
inline void set_eyes(thermovis::VisibleStereoFrame&, Fields&) {}
inline void set_eyes(thermovis::InfraredStereoFrame&, Fields&) {}

template <class Frame>
void set_header(Frame& frame, Fields& in) {
  frame.seq(in.next<std::uint64_t>());
  frame.pixel_format(in.next<std::uint32_t>());
  frame.width(in.next<std::uint32_t>());
  frame.height(in.next<std::uint32_t>());
  frame.step(in.next<std::uint32_t>());
  frame.capture_time_ns(in.next<std::int64_t>());
  for (thermovis::StageStamp& stamp : frame.stamps().stamps()) {
    stamp.stage(in.next<std::uint32_t>());
    stamp.duration_us(in.next<std::uint32_t>());
    stamp.end_ns(in.next<std::int64_t>());
  }
  set_eyes(frame, in);
}

template <class Array>
void check_inside(const cv::Mat& view, const Array& array, const char* what) {
  const auto* begin = reinterpret_cast<const std::uint8_t*>(array.data());
  const auto* end = begin + sizeof(typename Array::value_type) * array.size();
  if (view.empty()) tf::fail(what, "an empty view was returned");
  if (view.datastart < begin || view.dataend > end)
    tf::fail(what, "the view reaches outside its eye's array");
  volatile std::uint8_t sink = view.datastart[0];
  sink = view.dataend[-1];
  (void)sink;
}

// FrameError messages name the frame ("<what> frame <seq>: ..."), not a file.
template <class Body>
void accepted(Body&& body) {
  try {
    body();
  } catch (const tn::FrameError& e) {
    if (std::string(e.what()).find("frame") == std::string::npos)
      tf::fail("the error does not name the frame", e.what());
  } catch (const std::exception& e) {
    tf::fail(typeid(e).name(), e.what());
  }
}

template <class Frame, class... Grid>
void decode(const Frame& frame, const char* what, Grid... grid) {
  for (const tn::Eye eye : {tn::Eye::left, tn::Eye::right}) {
    accepted([&] {
      const cv::Mat view = tn::view(frame, eye, grid...);
      check_inside(view, eye == tn::Eye::left ? frame.left() : frame.right(), what);
    });
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Megabytes each: allocated once, reused by every input.
  static const auto visible = std::make_unique<thermovis::VisibleStereoFrame>();
  static const auto infrared = std::make_unique<thermovis::InfraredStereoFrame>();
  static const auto grid = std::make_unique<thermovis::GridStereoFrame>();
  Fields in(data, size);
  switch (in.next<std::uint8_t>() % 5) {
    case 0:
      set_header(*visible, in);
      decode(*visible, "visible");
      break;
    case 1:
      set_header(*infrared, in);
      decode(*infrared, "infrared");
      break;
    case 2:
      set_header(*grid, in);
      decode(*grid, "grid");
      break;
    case 3: {
      set_header(*grid, in);
      const cv::Size expected(in.next<std::int32_t>(), in.next<std::int32_t>());
      decode(*grid, "grid on a service's grid", expected);
      break;
    }
    default: {
      // A box from a detection or match message.
      thermovis::Box2D box;
      box.x(in.next<float>());
      box.y(in.next<float>());
      box.width(in.next<float>());
      box.height(in.next<float>());
      const cv::Rect rect = tn::to_rect(box);
      if (!rect.empty()) {
        // A box to work on covers the given one, inside the limits to_rect documents.
        if (!(rect.x <= box.x() && rect.y <= box.y() &&
              rect.x + rect.width >= box.x() + box.width() &&
              rect.y + rect.height >= box.y() + box.height()))
          tf::fail("to_rect", "the rectangle does not cover the box");
      }
      break;
    }
  }
  return 0;
}
