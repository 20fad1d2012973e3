#pragma once
// thermovis-match: per-target stereo correspondences. Each DetectionArray (from thermovis-detect
// or any other DDS application) is paired with the rectified stereo frames of the same capture,
// and each box of the left image is matched along its epipolar rows of the right image
// (match::match_box, sub-pixel). The correspondences go out on thermovis/matches with the band
// they were found in.
//
// Bands:
//  - visible: the rectified visible pair;
//  - infrared: the rectified infrared pair (raw counts, each box's surroundings stretched to
//    8 bits); its disparities follow the infrared baseline (the range stage knows);
//  - both (the default): every box on both pairs, published as two TargetMatch entries with the
//    detection's target id (band visible and band infrared); the range stage combines the two
//    pairs' ranges by their uncertainties (range::combine_ranges). When the array would exceed
//    its 64 targets, the infrared entries of the last boxes are left out;
//  - auto: visible first, and the infrared pair for a box where the visible one gives fewer
//    than `min_visible_points` correspondences (night, glare, a featureless box);
//  - fused: the fused pair. The infrared content of a fused image is registered at one distance,
//    so its disparities mix the two baselines (0.336 and 0.358 m for the paper rig): ranges are
//    biased by up to their difference (6 %); kept for comparison.
//
// Frames arrive before their detections (the detector works on them first), so the node keeps
// the images of the last few frames, keyed by sequence number; detections whose frames never
// arrive (or arrived too long ago) are dropped and counted.
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/match/stereo_match.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/node/pipeline_grid.hpp"
#include "thermovis/perception.h"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::match_service {

enum class BandChoice { visible, infrared, fused, automatic, both };
// "visible" | "infrared" | "fused" | "auto" | "both"; std::invalid_argument otherwise.
BandChoice parse_band(const std::string& name);

struct MatchConfig {
  node::GridOptions grid;
  BandChoice band = BandChoice::both;
  int min_visible_points = 8;  // auto: fewer visible correspondences -> try the infrared pair
  match::MatchOptions match;
  double min_distance_m = 2.5;  // nearest target searched (sets the largest disparity)
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
  MatchNode(transport::Participant& participant, const camera::Rig& rig, const MatchConfig& config,
            const std::string& service_name);
  ~MatchNode();
  void run();  // until node::stop_requested()
  MatchStats stats() const { return stats_; }

 private:
  struct Pair {
    std::uint64_t seq = 0;
    cv::Mat left, right;  // grey (visible, fused) or raw counts (infrared)
  };
  struct BandInput;  // a frame topic and the pairs kept from it
  void take_frames(BandInput& input);
  const Pair* find(BandInput& input, std::uint64_t seq);
  void answer(const DetectionArray& detections);
  match::MatchResult match_on(Band band, const Pair& pair, const cv::Rect& box) const;
  // The message entry of one detection's matches (the best-correlated points it has room for).
  TargetMatch target_match(const Detection& detection, Band band, match::MatchResult result);

  MatchConfig config_;
  cv::Size grid_size_;
  std::unique_ptr<BandInput> primary_;   // visible or fused (or infrared alone)
  std::unique_ptr<BandInput> infrared_;  // auto, both: the infrared pair
  transport::Reader<DetectionArray> detections_in_;
  transport::Writer<MatchArray> out_;
  node::HealthReporter health_;
  MatchStats stats_;
};

}  // namespace thermovis::match_service
