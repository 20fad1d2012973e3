#pragma once
// The fusion-ranging image: the fused left image (rectified, colour) with each target framed and
// its distance, uncertainty and band written beside the box, under a header holding the frame
// stamp (frame_stamp.hpp) and a status line (frame, capture-to-range latency, frames over the
// latency budget, DEADLINE misses). Also the other views a display offers: the rectified visible
// or infrared left image with the same boxes, and all three side by side.
//
// Coordinates: boxes are in pixels of the rectified left grid (x = column, y = row of the
// top-left corner), the grid every image here is on (the infrared registered onto the visible
// grid). Images are CV_8UC3 (BGR) or CV_8UC1; the output is always CV_8UC3.
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

namespace thermovis::display {

// What a display shows.
enum class View { fused, visible, infrared, side_by_side };
const char* to_string(View view);
std::optional<View> parse_view(const std::string& name);  // "fused", "visible", "infrared", "side"

// Bands a range was measured in (the values of thermovis::Band in the IDL).
inline constexpr std::uint32_t kBandVisible = 1;
inline constexpr std::uint32_t kBandInfrared = 2;
inline constexpr std::uint32_t kBandFused = 3;
const char* band_name(std::uint32_t band);  // "visible", "infrared", "fused", "-"

struct Target {
  std::uint32_t id = 0;
  std::string label;
  cv::Rect2f box;  // rectified left grid, px
  // Distance from the left visible camera's centre and its one-sigma uncertainty, m. NaN: the
  // target was detected but not ranged (drawn grey, without a distance).
  double distance_m = std::numeric_limits<double>::quiet_NaN();
  double sigma_m = 0.0;
  std::uint32_t band = 0;
  std::uint32_t points = 0;  // stereo points the distance rests on
  // An obstacle of thermovis/obstacles that is no ranged target (framed in magenta; its
  // distance is horizontal, to its near face).
  bool obstacle = false;
};

// What is drawn over the image besides the boxes: the free space (thermovis/obstacles), per
// grid column the row where the ground is free up to (NaN: unknown), drawn as a line.
struct Overlay {
  std::vector<float> free_space_row;
};

struct Status {
  std::uint64_t frame_seq = 0;
  std::int64_t capture_time_ns = 0;                              // Unix epoch; goes into the stamp
  double latency_ms = std::numeric_limits<double>::quiet_NaN();  // capture to range, this frame
  double deadline_ms = 20.0;                                     // the latency budget
  std::uint64_t frames = 0;           // frames that reached the output so far
  std::uint64_t over_deadline = 0;    // of which over deadline_ms
  std::uint64_t deadline_misses = 0;  // DEADLINE QoS misses reported by the services
  std::string note;                   // e.g. "no ranges for 2.0 s"; empty: nothing
};

// Rows above the image: the stamp (kStampCell rows) and the status line.
inline constexpr int kHeaderRows = 32;

// One image with boxes and header: kHeaderRows + image.rows rows, at least kStampWidth wide
// (a narrower image is padded on the right). Throws std::invalid_argument for an empty image or
// another pixel type.
cv::Mat compose(const cv::Mat& image, const std::vector<Target>& targets, const Status& status,
                const Overlay& overlay = {});

// Visible, infrared and fused side by side, each scaled by `panel_scale` and framed with the
// same boxes, under one header. Every panel must have the same size.
cv::Mat compose_side_by_side(const cv::Mat& visible, const cv::Mat& infrared, const cv::Mat& fused,
                             const std::vector<Target>& targets, const Status& status,
                             double panel_scale = 0.5, const Overlay& overlay = {});

// The text beside a target's box: "#3 10.04 +- 0.03 m IR" ("vehicle #3 ..." for classes other
// than person; "#3 no range" without a distance; "obstacle 12.3 m" for an obstacle).
std::string target_caption(const Target& target);

}  // namespace thermovis::display
