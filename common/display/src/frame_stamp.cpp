#include "thermovis/display/frame_stamp.hpp"

#include <array>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace thermovis::display {
namespace {

std::array<std::uint8_t, 8> stamp_bytes(std::uint64_t seq, std::int64_t capture_time_ns) {
  const std::uint64_t units =
      capture_time_ns > 0 ? static_cast<std::uint64_t>(capture_time_ns / kStampUnitNs) : 0;
  std::array<std::uint8_t, 8> bytes{};
  for (int i = 0; i < 6; ++i) bytes[static_cast<std::size_t>(i)] = (units >> (8 * (5 - i))) & 0xff;
  bytes[6] = static_cast<std::uint8_t>(seq & 0xff);
  unsigned sum = 0;
  for (int i = 0; i < 7; ++i) sum += bytes[static_cast<std::size_t>(i)];
  bytes[7] = static_cast<std::uint8_t>(sum & 0xff);
  return bytes;
}

}  // namespace

void draw_stamp(cv::Mat& image, std::uint64_t seq, std::int64_t capture_time_ns) {
  if ((image.type() != CV_8UC3 && image.type() != CV_8UC1) || image.cols < kStampWidth ||
      image.rows < kStampCell) {
    throw std::invalid_argument("frame stamp needs an 8-bit image of at least " +
                                std::to_string(kStampWidth) + "x" + std::to_string(kStampCell) +
                                " px");
  }
  const auto bytes = stamp_bytes(seq, capture_time_ns);
  for (int bit = 0; bit < kStampBits; ++bit) {
    const bool one = (bytes[static_cast<std::size_t>(bit / 8)] >> (7 - bit % 8)) & 1;
    image(cv::Rect(bit * kStampCell, 0, kStampCell, kStampCell))
        .setTo(one ? cv::Scalar::all(255) : cv::Scalar::all(0));
  }
}

std::optional<FrameStamp> read_stamp(const cv::Mat& image) {
  if ((image.type() != CV_8UC3 && image.type() != CV_8UC1) || image.cols < kStampWidth ||
      image.rows < kStampCell)
    return std::nullopt;
  std::array<std::uint8_t, 8> bytes{};
  for (int bit = 0; bit < kStampBits; ++bit) {
    // The mean of the cell's central 4x4 pixels: JPEG ringing stays at the cell's edges.
    const cv::Scalar mean =
        cv::mean(image(cv::Rect(bit * kStampCell + 2, 2, kStampCell - 4, kStampCell - 4)));
    double level = 0;
    for (int c = 0; c < image.channels(); ++c) level += mean[c];
    level /= image.channels();
    if (level >= 128) bytes[static_cast<std::size_t>(bit / 8)] |= 1u << (7 - bit % 8);
  }
  unsigned sum = 0;
  for (int i = 0; i < 7; ++i) sum += bytes[static_cast<std::size_t>(i)];
  if ((sum & 0xff) != bytes[7]) return std::nullopt;
  std::uint64_t units = 0;
  for (int i = 0; i < 6; ++i) units = (units << 8) | bytes[static_cast<std::size_t>(i)];
  if (units == 0) return std::nullopt;  // an all-black corner is no stamp
  FrameStamp stamp;
  stamp.seq_mod_256 = bytes[6];
  stamp.capture_time_ns = static_cast<std::int64_t>(units) * kStampUnitNs;
  return stamp;
}

}  // namespace thermovis::display
