#pragma once
// IDL frame <-> cv::Mat. The views are Mat headers over the frame's own arrays (no copy): a view
// of a loaned sample is valid as long as the loan. Every view checks the frame's header fields
// first and throws FrameError naming the topic-independent problem (size, format).
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <stdexcept>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/perception.h"
#include "thermovis/pipeline/bands.hpp"

namespace thermovis::node {

class FrameError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using Eye = pipeline::Eye;

// OpenCV type of a pixel format (CV_8UC3, CV_8UC1, CV_16UC1); FrameError for unknown ones.
int cv_type_of(PixelFormat format);
PixelFormat pixel_format_of(int cv_type);

// Read-only views of received frames. FrameError, naming the frame and its seq, when the pixel
// format is unknown (or not the type's), the image is empty or does not fit the type's array, or
// `step` is not the packed row (width x bytes per pixel: rows are never padded); for grid
// frames also when `eyes` is unknown or the right eye of a left-only frame is asked for.
cv::Mat view(const VisibleStereoFrame& frame, Eye eye);
cv::Mat view(const InfraredStereoFrame& frame, Eye eye);
cv::Mat view(const GridStereoFrame& frame, Eye eye);
// The same, also checking that the frame is on the grid the reading service works on, and (with
// geometry_id) that it was made on the geometry the service holds (a frame that says none, 0,
// passes that check).
cv::Mat view(const GridStereoFrame& frame, Eye eye, cv::Size grid);
cv::Mat view(const GridStereoFrame& frame, Eye eye, cv::Size grid, std::uint32_t geometry_id);

// Writable views into frames being filled (e.g. a loaned sample): sets width, height, step and
// pixel_format, returns the Mat to render or copy into. FrameError when `size` does not fit.
cv::Mat prepare(VisibleStereoFrame& frame, Eye eye, cv::Size size);
cv::Mat prepare(InfraredStereoFrame& frame, Eye eye, cv::Size size);
cv::Mat prepare(GridStereoFrame& frame, Eye eye, cv::Size size, int cv_type);

// The per-stage stamps a received message carries (frames, detections, matches): FrameError
// naming `what` when an entry holds an unknown stage, stages are out of pipeline order (each
// stage comes after the one before it, unused entries only at the end) or a stage ends more
// than kStampSkewNs before the capture or the stage before it (stamps of several hosts differ
// by their clock offsets, which the lab keeps far under a second).
inline constexpr std::int64_t kStampSkewNs = 1'000'000'000;
void check_stamps(const PipelineStamps& stamps, std::int64_t capture_ns, const std::string& what);

// A frame's capture-to-output latency above this is no latency but a wrong stamp: the frame
// topics keep the last two frames, so no frame waits seconds anywhere in the pipeline.
inline constexpr std::int64_t kMaxFrameLatencyNs = 10'000'000'000;
// A FrameTiming sample (thermovis/timing) fit for latency statistics: FrameError naming the
// frame when its stamps fail check_stamps, its output is before its capture or more than
// kStampSkewNs before the end of its last stage, its latency exceeds kMaxFrameLatencyNs, or a
// stage lasted longer than the whole latency (plus kStampSkewNs).
void check_timing(const FrameTiming& timing);

// The order of the frames a reader takes from one topic. A writer's frames come in seq order; a
// seq at or below the last one is the same capture again (repeated), an older capture arriving
// late (stale: capture time not after the last one's), or a writer that restarted and counts
// from the start again (restarted: later capture time), which the reader follows.
class FrameOrder {
 public:
  enum class Verdict { next, repeated, stale, restarted };
  // Classifies a frame; `next` and `restarted` make it the last one.
  Verdict check(std::uint64_t seq, std::int64_t capture_ns);
  std::uint64_t last_seq() const { return last_seq_; }

 private:
  bool any_ = false;
  std::uint64_t last_seq_ = 0;
  std::int64_t last_capture_ns_ = 0;
};

// The band of a measurement <-> the messages' BAND_* values. band_of: BAND_UNKNOWN (a writer that
// does not say) is the visible band; FrameError for a value beyond BAND_FUSED.
Band to_message(pipeline::Band band);
pipeline::Band band_of(Band band);

// Boxes of the perception messages <-> OpenCV rectangles (pixels of the rectified left image).
// to_rect rounds outwards and gives an empty rectangle for a box with a non-finite field.
cv::Rect to_rect(const Box2D& box);
Box2D to_box(const cv::Rect& rect);

}  // namespace thermovis::node
