#pragma once
// The bridge: paces a frame source at the capture rate and publishes each capture as a visible
// and an infrared stereo frame, rendered straight into loaned DDS samples (no copy). A slow
// reader never blocks it: when the writer's pool has no free sample the capture is dropped and
// counted.
#include <chrono>
#include <cstdint>
#include <memory>

#include "frame_source.hpp"
#include "thermovis/frames.h"
#include "thermovis/node/health.hpp"
#include "thermovis/transport/frames.hpp"

namespace thermovis::bridge {

struct BridgeConfig {
  double rate_hz = 50.0;    // captures per second (self-paced sources: ignored)
  std::int64_t frames = 0;  // stop after this many captures; 0 = run until stopped
  std::chrono::nanoseconds deadline{20'000'000};  // DEADLINE QoS period of the frame topics
  std::int32_t depth = 2;                         // KEEP_LAST depth of the frame topics
  std::int32_t max_readers = 2;                   // readers that may hold a frame at once
};

struct BridgeStats {
  std::uint64_t published = 0;       // captures published (both frames)
  std::uint64_t dropped = 0;         // captures lost: no free sample, or the loop fell behind
  std::uint64_t bad = 0;             // captures the source could not deliver
  std::uint64_t source_skipped = 0;  // captures the source lost before the bridge took them
};

class BridgeNode {
 public:
  BridgeNode(transport::Participant& participant, std::unique_ptr<FrameSource> source,
             const BridgeConfig& config, const std::string& service_name);
  // Runs until node::stop_requested(), the configured frame count or the end of the source.
  // Paces the source at rate_hz unless the source paces itself (FrameSource::self_paced).
  void run();
  BridgeStats stats() const { return stats_; }

 private:
  bool publish_capture(std::int64_t index);
  // The health message while the source prepares (FrameSource::preparing), then "processing".
  void report_preparing(std::int64_t index);

  std::unique_ptr<FrameSource> source_;
  BridgeConfig config_;
  // Each with its packed twin for readers on other hosts (transport/frames.hpp).
  transport::FrameWriter<VisibleStereoFrame> visible_;
  transport::FrameWriter<InfraredStereoFrame> infrared_;
  node::HealthReporter health_;
  BridgeStats stats_;
  bool preparing_ = true;  // until the source said it no longer prepares
};

}  // namespace thermovis::bridge
