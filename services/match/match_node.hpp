#pragma once
// thermovis-match: per-target stereo correspondences. Each DetectionArray (from thermovis-detect
// or any other DDS application) is joined with the rectified stereo frames of the same capture,
// and each box of the left image is matched on the pairs the band choice names
// (pipeline::MatchStage: along its epipolar rows of the right image, sub-pixel). The
// correspondences go out on thermovis/matches with the band they were found in; with --band
// both a box gives two TargetMatch entries with the detection's target id (visible and
// infrared), all infrared entries after the visible ones, so that an array at its 64 targets
// loses infrared entries first. The grid comes from thermovis/geometry.
//
// Frames arrive before their detections (the detector works on them first), so the node keeps
// the images of the last few frames, keyed by sequence number; detections whose frames never
// arrive (or arrived too long ago) are dropped and counted.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/node/frame_join.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/perception.h"
#include "thermovis/pipeline/match_stage.hpp"
#include "thermovis/transport/frames.hpp"

namespace thermovis::match_service {

struct MatchConfig {
  pipeline::MatchStageOptions match;
  std::size_t frames_kept = 4;  // frames kept per band for detections still to come
  std::chrono::nanoseconds deadline{20'000'000};
};

struct MatchStats {
  std::uint64_t processed = 0;         // detection arrays answered
  std::uint64_t no_frame = 0;          // detection arrays whose frames were not (or no longer) here
  std::uint64_t bad = 0;               // frames or detections rejected
  std::uint64_t overwritten = 0;       // frames reused by their writer while copied (dropped)
  std::uint64_t points = 0;            // correspondences published
  std::uint64_t infrared_targets = 0;  // targets matched on the infrared pair
  std::uint64_t infrared_left_out = 0;  // both: infrared entries with no room in the array
};

class MatchNode {
 public:
  MatchNode(transport::Participant& participant, const MatchConfig& config,
            const std::string& service_name);
  ~MatchNode();
  void run();  // until node::stop_requested()
  MatchStats stats() const { return stats_; }

 private:
  struct Pair {
    cv::Mat left, right;  // grey (visible, fused) or raw counts (infrared)
  };
  struct BandInput;  // a frame topic and the pairs kept from it
  void take_frames(BandInput& input);
  const Pair* find(BandInput& input, std::uint64_t seq);
  void answer(const DetectionArray& detections);
  // Every detection's box matched on `images`, the entries appended to `into`. Throws
  // std::invalid_argument for a box with no area.
  void match_boxes(const DetectionArray& detections, const pipeline::MatchImages& images,
                   std::vector<TargetMatch>& into);
  // The message entry of one detection's matches (the best-correlated points it has room for).
  TargetMatch target_match(const Detection& detection, pipeline::Band band,
                           match::MatchResult result);

  MatchConfig config_;
  node::StageOnGeometry<pipeline::MatchStage, pipeline::MatchStageOptions> stage_;
  std::unique_ptr<BandInput> primary_;   // visible or fused (absent for --band infrared)
  std::unique_ptr<BandInput> infrared_;  // infrared, auto, both: the infrared pair
  transport::Reader<DetectionArray> detections_in_;
  transport::Writer<MatchArray> out_;
  node::HealthReporter health_;
  MatchStats stats_;
};

}  // namespace thermovis::match_service
