#pragma once
// thermovis-obstacles: objects of any class standing in the way, and the free space before the
// vehicle, from the rectified pairs (pipeline::ObstacleStage: stixels on each pair's ground).
// Each capture's infrared pair is searched as it arrives (it is published first) and its visible
// pair after it; the two pairs' obstacles are combined, merged with the targets the target path
// ranged on the same capture (thermovis/ranges: a person keeps its label and range and is not
// reported twice), and published on the public topic thermovis/obstacles (ObstacleArray,
// RELIABLE). The grid comes from thermovis/geometry.
//
// The ranges of a capture come about when its obstacles are done: a capture waits for them at
// most range_wait, and not at all while no range has come for a second (no target path runs).
// Frames are read on their loans, never copied.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/node/frame_join.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/obstacles.h"
#include "thermovis/perception.h"
#include "thermovis/pipeline/obstacle_stage.hpp"
#include "thermovis/transport/frames.hpp"

namespace thermovis::obstacles_service {

struct ObstaclesConfig {
  pipeline::ObstacleStageOptions obstacles;
  std::chrono::milliseconds range_wait{15};  // a capture waits this long for its ranges
  bool with_targets = true;                  // merge the ranges of thermovis/ranges
  // Each pair's ground searched about its last capture's (obstacle::GroundTracker), the
  // mounting's prior when that fails: a vehicle that pitches. Off: about the prior every time.
  bool track_ground = false;
  // A capture whose other pair has not come this long after its first is published with the
  // one pair it has.
  std::chrono::milliseconds partner_wait{25};
};

struct ObstaclesStats {
  std::uint64_t processed = 0;       // obstacle arrays published
  std::uint64_t one_pair = 0;        // of which with one pair only (the other never came)
  std::uint64_t without_ranges = 0;  // of which without their capture's ranges
  std::uint64_t bad = 0;             // frames or ranges rejected
  std::uint64_t overwritten = 0;     // frames reused by their writer while read (dropped)
  std::uint64_t skipped = 0;         // frames left for a newer one (this service behind)
  std::uint64_t no_ground = 0;       // pairs searched that found no ground
  std::uint64_t obstacles = 0;       // obstacles published
  std::uint64_t targets = 0;         // of which ranged targets
};

// The stage's targets from one range array: FrameError naming the target for a box with no area
// or a non-finite field.
std::vector<pipeline::RangedTarget3d> targets_of(const RangeArray& ranges);
// The message of one capture's report.
ObstacleArray to_message(const pipeline::ObstacleReport& report,
                         const obstacle::ObstacleResult& result,
                         const pipeline::ObstacleStage& stage);

class ObstaclesNode {
 public:
  ObstaclesNode(transport::Participant& participant, const ObstaclesConfig& config,
                const std::string& service_name);
  ~ObstaclesNode();
  void run();  // until node::stop_requested()
  ObstaclesStats stats() const { return stats_; }

 private:
  struct BandInput;
  // A capture whose pairs are being searched.
  struct Capture {
    std::int64_t capture_ns = 0;
    PipelineStamps stamps;  // the first pair's frame's
    std::int64_t start_ns = 0;
    std::chrono::steady_clock::time_point first_seen;
    std::optional<obstacle::PairObstacles> visible, infrared;
  };
  void take_frames(BandInput& input);
  void take_ranges();
  // Publishes, oldest first, the captures that have every pair searched or will get no more.
  void publish_ready();
  void publish(std::uint64_t seq, Capture& capture);

  ObstaclesConfig config_;
  node::StageOnGeometry<pipeline::ObstacleStage, pipeline::ObstacleStageOptions> stage_;
  std::unique_ptr<BandInput> visible_, infrared_;
  std::unique_ptr<transport::Reader<RangeArray>> ranges_in_;
  transport::Writer<ObstacleArray> out_;
  node::HealthReporter health_;
  std::map<std::uint64_t, Capture> captures_;  // by seq
  obstacle::GroundTracks tracks_;              // with track_ground
  std::uint32_t tracked_geometry_ = 0;         // the geometry id the tracks were made on
  node::SeqBuffer<RangeArray> ranges_;
  std::chrono::steady_clock::time_point last_range_{};
  ObstaclesStats stats_;
};

}  // namespace thermovis::obstacles_service
