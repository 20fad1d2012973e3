#pragma once
// thermovis-view's DDS side: reads the fused and rectified frames, detections, ranges, obstacles,
// timing and health; composes the fusion-ranging image (display::compose) at a bounded rate,
// publishes it on thermovis/display and encodes the views web clients ask for into the ViewHub.
//
// It must never slow the pipeline: frame readers keep the last 2 samples and this loop takes
// them all, copies only the newest left image of the bands some view needs (a fraction of a
// millisecond) and gives the loans back at once. The rectified bands are read only while a view
// needs them (see take_frames); composing and encoding happen at most
// `max_fps` times a second, from the newest range result whose fused frame it holds (older ones
// are skipped). HTTP clients never touch this loop.
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "thermovis/display/ranging_image.hpp"
#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/frames.h"
#include "thermovis/node/health.hpp"
#include "thermovis/transport/frames.hpp"
#include "view_hub.hpp"
#include "view_status.hpp"

namespace thermovis::view {

struct ViewConfig {
  double max_fps = 15.0;        // compositions (and encodes per wanted view) per second
  int jpeg_quality = 80;        // 0..100
  double deadline_ms = 20.0;    // the latency budget drawn and counted
  double history_s = 10.0;      // latency plot window
  double panel_scale = 0.5;     // side-by-side panels
  double stale_ranges_s = 0.5;  // without ranges this long, show the newest fused frame bare
};

class ViewNode {
 public:
  ViewNode(transport::Participant& participant, ViewHub& hub, const ViewConfig& config,
           const std::string& service_name);
  void run();  // until node::stop_requested()
  ViewStats stats() const { return stats_; }

  // One band's left image of one frame, copied out of its loan.
  struct Image {
    std::uint64_t seq = 0;
    std::int64_t capture_time_ns = 0;
    cv::Mat left;
  };

 private:
  void take_frames();
  void take_messages();
  void maybe_compose();
  void compose(const Image& fused, const RangeResult* ranges, const std::string& note);
  const Image* find(const std::deque<Image>& ring, std::uint64_t seq) const;
  void update_status_json();

  ViewHub& hub_;
  ViewConfig config_;
  transport::Participant& participant_;
  transport::FrameReader<GridStereoFrame> fused_in_;
  // Created while a view needs the band, deleted when none has for ViewHub::wanted's window.
  std::optional<transport::FrameReader<GridStereoFrame>> visible_in_, infrared_in_;
  transport::Reader<DetectionArray> detections_in_;
  transport::Reader<RangeArray> ranges_in_;
  transport::Reader<ObstacleArray> obstacles_in_;
  transport::Reader<FrameTiming> timing_in_;
  transport::Reader<Health> health_in_;
  transport::FrameWriter<GridStereoFrame> display_out_;
  node::HealthReporter health_;
  enhance::InfraredAgc agc_;

  std::deque<Image> fused_, visible_, infrared_;  // newest last, a few frames each
  std::deque<RangeResult> ranges_;                // newest last
  std::deque<ObstacleResult> obstacles_;          // newest last
  // The obstacles drawn with frame `seq`: its own, else the newest before it (they come about
  // with the ranges, sometimes after them); nullptr when none is held.
  const ObstacleResult* obstacles_for(std::uint64_t seq) const;
  std::map<std::uint64_t, std::vector<display::Target>> detections_;  // by seq, a few
  std::uint64_t last_composed_seq_ = 0;
  std::chrono::steady_clock::time_point last_compose_{};
  std::int64_t last_range_ns_ = 0;
  std::uint64_t encoded_number_[ViewHub::kViews] = {};
  PipelineStatus pipeline_;  // latency and health of the services
  std::chrono::steady_clock::time_point last_status_{};
  ViewStats stats_;
};

}  // namespace thermovis::view
