#pragma once
// A machine-readable stamp drawn into the top-left corner of a displayed image: which frame it
// shows and when that frame was captured, so whoever shows the image (the viewer's web page, a
// test reading a screenshot) can tell how old the pixels are without any side channel.
//
// Layout: kStampBits cells of kStampCell x kStampCell px in one row from (0, 0), white = 1,
// black = 0, most significant bit first. Cells are aligned to the 8x8 blocks of JPEG, so the
// stamp survives compression at any usual quality: each cell is read at its centre against
// mid-grey. Bits 0-47: capture time in units of 100 us since the Unix epoch (CLOCK_REALTIME,
// like every *_ns stamp of the pipeline); bits 48-55: the frame's sequence number modulo 256;
// bits 56-63: the sum of the seven bytes before, modulo 256 (tells a stamp from image content).
#include <cstdint>
#include <optional>

#include <opencv2/core/mat.hpp>

namespace thermovis::display {

inline constexpr int kStampBits = 64;
inline constexpr int kStampCell = 8;  // px; one JPEG block
inline constexpr int kStampWidth = kStampBits * kStampCell;
inline constexpr std::int64_t kStampUnitNs = 100'000;  // resolution of the capture time

struct FrameStamp {
  std::uint8_t seq_mod_256 = 0;
  std::int64_t capture_time_ns = 0;  // rounded down to kStampUnitNs
};

// Draws the stamp into rows 0..kStampCell-1 of a CV_8UC3 or CV_8UC1 image at least kStampWidth
// wide. Throws std::invalid_argument otherwise.
void draw_stamp(cv::Mat& image, std::uint64_t seq, std::int64_t capture_time_ns);

// Reads a stamp back; nothing when the image is too small or the checksum does not match.
std::optional<FrameStamp> read_stamp(const cv::Mat& image);

}  // namespace thermovis::display
