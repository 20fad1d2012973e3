#pragma once
// thermovis-rectify-fuse: raw visible + infrared stereo frames -> both bands on the pipeline grid
// and the fused images (pipeline::RectifyFuseStage), each written in place into a loaned sample:
// rectified visible (BGR8), rectified infrared (MONO16 raw counts) and fused (BGR8; left eye, both
// with fuse_right_eye). Publishes the grid's geometry on thermovis/geometry (latched) and stamps
// every grid frame with its id. Only the newest capture is processed: older ones waiting are
// dropped and counted. The fusion runs only while thermovis/fused has a reader (the display, a
// recording, fused-band matching, another application): in the default pipeline nothing reads
// it, and it was a third of this service's CPU. Each grid topic has its packed twin for readers
// on other hosts (transport/frames.hpp), filled only while such a reader is matched.
#include <array>
#include <chrono>
#include <memory>

#include "thermovis/frames.h"
#include "thermovis/node/frame_join.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/pipeline/rectify_fuse_stage.hpp"
#include "thermovis/transport/frames.hpp"

namespace thermovis::rectify_fuse {

struct RectifyFuseConfig {
  pipeline::GridOptions grid;
  pipeline::RectifyFuseOptions stage;
  // The display needs the left eye fused; only matching on the fused band needs the right one.
  bool fuse_right_eye = false;
  // The visible pair rectified on a second thread while this one rectifies the infrared: both
  // pairs out sooner when a core is free; on the 2-core reference machine, whose cores the
  // pipeline keeps busy, it delayed the infrared pair (rectify-fuse stage p50 12-14 ms instead
  // of 5.2) without more captures answered, so it is off by default.
  bool parallel_bands = false;
  // The left eye's fusion (the display's image) at most this many captures a second, 0: every
  // capture. The display composes 15 pictures a second, and fusing every capture at 50 Hz took
  // 7-9 ms of CPU per capture beside the pipeline. A capture is fused when 0.9 / rate has
  // passed since the last fused capture (25 Hz: every other capture at 50 Hz); the fused
  // writer's DEADLINE is then the pipeline's plus 1 / rate. Ignored with fuse_right_eye:
  // fused-band matching needs every capture.
  double fused_rate_hz = 0.0;
  std::chrono::nanoseconds deadline{20'000'000};
};

struct RectifyFuseStats {
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;   // captures superseded, or without their infrared partner
  std::uint64_t bad = 0;       // frames rejected (bad header, size mismatch, out of order)
  std::uint64_t repeated = 0;  // captures received again, skipped
  std::uint64_t fused = 0;     // processed captures fused (only while thermovis/fused has a reader)
  std::uint64_t fusion_skipped = 0;  // captures not fused under fused_rate_hz
};

class RectifyFuseNode {
 public:
  RectifyFuseNode(transport::Participant& participant, const camera::Rig& rig,
                  const RectifyFuseConfig& config, const std::string& service_name);
  void run();  // until node::stop_requested()
  RectifyFuseStats stats() const;
  cv::Size grid_size() const { return stage_.grid_size(); }

 private:
  // An infrared frame taken and held (a loan) until its visible partner comes.
  struct HeldInfrared {
    std::shared_ptr<transport::FrameSamples<InfraredStereoFrame>> samples;
    std::size_t index = 0;
    const InfraredStereoFrame& frame() const { return (*samples)[index]; }
  };
  void take_infrared(std::chrono::milliseconds wait);
  void process(const VisibleStereoFrame& visible, const InfraredStereoFrame& infrared);
  // The fused frame of a processed capture, when thermovis/fused has a reader.
  void fuse(const std::array<cv::Mat, 2>& rect_infrared, const std::array<cv::Mat, 2>& rect_visible,
            const VisibleStereoFrame& visible);

  RectifyFuseConfig config_;
  pipeline::RectifyFuseStage stage_;
  std::uint32_t geometry_id_;
  transport::FrameReader<VisibleStereoFrame> visible_in_;
  transport::FrameReader<InfraredStereoFrame> infrared_in_;
  transport::FrameWriter<GridStereoFrame> rectified_visible_out_;
  transport::FrameWriter<GridStereoFrame> rectified_infrared_out_;
  transport::FrameWriter<GridStereoFrame> fused_out_;
  node::GeometryPublisher geometry_out_;
  node::HealthReporter health_;
  RectifyFuseStats stats_;
  node::FrameSequence sequence_;  // of the visible frames taken
  node::SeqBuffer<HeldInfrared> infrared_held_;
  bool fused_had_readers_ =
      false;  // thermovis/fused was written for a reader since its writer was made
  std::int64_t last_fused_capture_ns_ = 0;  // capture time of the last capture fused
};

}  // namespace thermovis::rectify_fuse
