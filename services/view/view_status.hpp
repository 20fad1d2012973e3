#pragma once
// What thermovis-view shows besides pictures, built from the pipeline's messages without DDS:
// the targets drawn (from thermovis/ranges and thermovis/detections), the latency window (from
// thermovis/timing) and each service's health (thermovis/health), and the JSON the page polls
// (/targets.json, /status.json).
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "thermovis/display/ranging_image.hpp"
#include "thermovis/health.h"
#include "thermovis/obstacles.h"
#include "thermovis/perception.h"

namespace thermovis::view {

struct ViewStats {
  std::uint64_t fused_frames = 0;  // fused frames received
  std::uint64_t copied = 0;        // left images copied out of loans
  std::uint64_t overwritten = 0;   // loans reused by the writer while copied (dropped)
  std::uint64_t bad = 0;           // frames rejected (bad header, or a packed frame that did not
                                   // unpack)
  std::uint64_t range_arrays = 0;  // range results received
  std::uint64_t composed = 0;      // fusion-ranging images made
  std::uint64_t encoded = 0;       // JPEGs made (all views)
  std::uint64_t published = 0;     // thermovis/display samples
};

display::Target target_of(const TargetRange& range);
display::Target target_of(const Detection& detection);
std::vector<display::Target> targets_of(const DetectionArray& detections);

// One thermovis/ranges sample as the viewer keeps it.
struct RangeResult {
  std::uint64_t seq = 0;
  std::int64_t capture_time_ns = 0;
  std::int64_t received_ns = 0;  // Unix epoch
  double latency_ms = 0.0;       // capture to the range service's output
  std::vector<display::Target> targets;
};
RangeResult range_result_of(const RangeArray& ranges, std::int64_t received_ns);

// One capture's obstacles (thermovis/obstacles) as drawn: those that are no ranged target
// (display::Target::obstacle; a ranged target is drawn from its range) and the free space.
struct ObstacleResult {
  std::uint64_t seq = 0;
  std::vector<display::Target> obstacles;
  display::Overlay overlay;
};
ObstacleResult obstacle_result_of(const ObstacleArray& obstacles);

// /targets.json of one composed frame: its seq, capture time, latency and note from `status`,
// and `targets` (a distance or latency that is not finite is written as -1).
std::string targets_json(const display::Status& status,
                         const std::vector<display::Target>& targets);

// The pipeline's latency over the last `history_s` seconds and the newest health of every
// service. Times are Unix epoch nanoseconds as the viewer received the samples.
class PipelineStatus {
 public:
  PipelineStatus(double deadline_ms, double history_s)
      : deadline_ms_(deadline_ms), history_s_(history_s) {}

  // Adds one frame's capture-to-output latency and drops what left the window by `now_ns`.
  void add_timing(const FrameTiming& timing, std::int64_t now_ns);
  void forget_old(std::int64_t now_ns);
  void add_health(const Health& health, std::int64_t now_ns);
  // Frames counted, frames over the deadline and the services' DDS deadline misses.
  void fill(display::Status& status) const;
  // /status.json at `now_ns`, with the viewer's own counters.
  std::string json(std::int64_t now_ns, const ViewStats& view) const;

 private:
  double deadline_ms_, history_s_;
  // (receive time, capture-to-output ms), oldest first.
  std::deque<std::pair<std::int64_t, double>> latency_;
  std::uint64_t frames_ = 0, over_deadline_ = 0;
  struct Service {
    Health health;
    std::int64_t seen_ns = 0;
  };
  std::map<std::string, Service> services_;
};

}  // namespace thermovis::view
