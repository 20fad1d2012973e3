#pragma once
// What the viewer's DDS loop hands to its HTTP threads: the newest JPEG of every view, the
// targets and status as JSON text, and the display-latency reports of the pages. The DDS loop
// only ever replaces a pointer under a short lock; HTTP threads wait here (never in a DDS
// callback), so a slow or stalled client cannot hold up the reading of frames.
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "thermovis/display/ranging_image.hpp"

namespace thermovis::view {

struct EncodedFrame {
  std::uint64_t number = 0;  // per view, +1 per encoded frame
  std::uint64_t seq = 0;     // pipeline frame shown
  std::int64_t capture_time_ns = 0;
  std::int64_t encoded_ns = 0;  // when the JPEG was ready (Unix epoch)
  std::string jpeg;
};

// `image` (8-bit, 1 or 3 channels) as a JPEG of `quality` (0..100); the caller numbers, stamps and
// times the frame.
std::shared_ptr<EncodedFrame> encode_jpeg(const cv::Mat& image, int quality);

// One frame the page showed: capture time from the stamp in its pixels, and when it appeared.
struct DisplaySample {
  std::int64_t capture_time_ns = 0;
  std::int64_t shown_ns = 0;  // Unix epoch, the browser's clock (the same host's clock)
};

class ViewHub {
 public:
  static constexpr std::size_t kViews = 4;
  using Clock = std::chrono::steady_clock;

  // --- DDS loop side
  void publish(display::View view, std::shared_ptr<const EncodedFrame> frame);
  void set_targets_json(std::string json);
  void set_status_json(std::string json);
  // True when a client asked for `view` within the last `within`: only those are encoded.
  bool wanted(display::View view, Clock::duration within = std::chrono::seconds(2)) const;
  // The composition log: capture time -> when the range result arrived and when it was
  // encoded, to split a display latency into the pipeline's part and the viewer's.
  void note_composed(std::int64_t capture_time_ns, std::int64_t range_ns, std::int64_t encoded_ns);

  // --- HTTP side
  void want(display::View view);
  // The newest frame of `view` numbered above `after`; waits up to `timeout` for one. Null on
  // timeout or stop.
  std::shared_ptr<const EncodedFrame> wait_frame(display::View view, std::uint64_t after,
                                                 std::chrono::milliseconds timeout);
  std::shared_ptr<const EncodedFrame> latest(display::View view) const;
  std::string targets_json() const;
  std::string status_json() const;
  void add_display_samples(const std::vector<DisplaySample>& samples);
  // p50/p95/max of capture->shown and its parts: capture->range (the pipeline), range->encoded
  // (the viewer: waiting for its composition slot, composing, encoding) and encoded->shown (HTTP
  // and the browser), over the last kMaxMeasured frames shown, as JSON.
  std::string display_latency_json() const;

  void stop();  // wakes every waiter; wait_frame returns null from then on
  bool stopped() const;

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool stopped_ = false;
  std::array<std::shared_ptr<const EncodedFrame>, kViews> frames_{};
  std::array<Clock::time_point, kViews> wanted_at_{};
  std::string targets_json_ = "{\"targets\":[]}";
  std::string status_json_ = "{}";
  struct Composed {
    std::int64_t capture_time_ns, range_ns, encoded_ns;
  };
  std::deque<Composed> composed_;  // the last few hundred compositions
  struct Measured {
    double capture_to_shown_ms, capture_to_range_ms, range_to_encoded_ms, encoded_to_shown_ms;
  };
  std::deque<Measured> measured_;  // the last kMaxMeasured frames shown
  static constexpr std::size_t kMaxComposed = 512;
  static constexpr std::size_t kMaxMeasured = 2000;
};

}  // namespace thermovis::view
