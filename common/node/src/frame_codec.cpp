#include "thermovis/node/frame_codec.hpp"

#include <cmath>
#include <string>

namespace thermovis::node {
namespace {

std::string size_text(std::uint32_t width, std::uint32_t height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// Checks the header of a frame against its array capacity; returns the Mat type.
template <class Frame>
int checked_type(const char* what, const Frame& f, std::size_t capacity_bytes,
                 PixelFormat expected = 0) {
  const std::string frame = std::string(what) + " frame " + std::to_string(f.seq());
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

template <class Array>
void* eye_data(const Array& left, const Array& right, Eye eye) {
  return const_cast<void*>(static_cast<const void*>(eye == Eye::left ? left.data() : right.data()));
}

}  // namespace

int cv_type_of(PixelFormat format) {
  switch (format) {
    case PIXEL_FORMAT_BGR8:
      return CV_8UC3;
    case PIXEL_FORMAT_MONO8:
      return CV_8UC1;
    case PIXEL_FORMAT_MONO16:
      return CV_16UC1;
    default:
      throw FrameError("unknown pixel format " + std::to_string(format));
  }
}

PixelFormat pixel_format_of(int cv_type) {
  switch (cv_type) {
    case CV_8UC3:
      return PIXEL_FORMAT_BGR8;
    case CV_8UC1:
      return PIXEL_FORMAT_MONO8;
    case CV_16UC1:
      return PIXEL_FORMAT_MONO16;
    default:
      throw FrameError("no pixel format for OpenCV type " + std::to_string(cv_type));
  }
}

cv::Mat view(const VisibleStereoFrame& f, Eye eye) {
  const int type = checked_type("visible", f, f.left().size(), PIXEL_FORMAT_BGR8);
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

cv::Mat view(const InfraredStereoFrame& f, Eye eye) {
  const int type =
      checked_type("infrared", f, f.left().size() * sizeof(std::uint16_t), PIXEL_FORMAT_MONO16);
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

cv::Mat view(const GridStereoFrame& f, Eye eye) {
  const int type = checked_type("grid", f, f.left().size());
  return cv::Mat(static_cast<int>(f.height()), static_cast<int>(f.width()), type,
                 eye_data(f.left(), f.right(), eye));
}

cv::Mat prepare(VisibleStereoFrame& f, Eye eye, cv::Size size) {
  f.pixel_format(PIXEL_FORMAT_BGR8);
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view(f, eye);
}

cv::Mat prepare(InfraredStereoFrame& f, Eye eye, cv::Size size) {
  f.pixel_format(PIXEL_FORMAT_MONO16);
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view(f, eye);
}

cv::Mat prepare(GridStereoFrame& f, Eye eye, cv::Size size, int cv_type) {
  f.pixel_format(pixel_format_of(cv_type));
  f.width(static_cast<std::uint32_t>(size.width));
  f.height(static_cast<std::uint32_t>(size.height));
  f.step(static_cast<std::uint32_t>(packed_step(f)));
  return view(f, eye);
}

cv::Mat view(const GridStereoFrame& f, Eye eye, cv::Size grid) {
  if (static_cast<int>(f.width()) != grid.width || static_cast<int>(f.height()) != grid.height) {
    throw FrameError(
        "grid frame " + std::to_string(f.seq()) + ": " + size_text(f.width(), f.height()) +
        " image, this service's grid is " +
        size_text(static_cast<std::uint32_t>(grid.width), static_cast<std::uint32_t>(grid.height)) +
        " (give every service the same --grid-scale and --projection)");
  }
  return view(f, eye);
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
