#pragma once
// thermovis-range: the last stage. Each target's correspondences (thermovis/matches) are ranged
// by pipeline::RangeStage on the geometry of thermovis/geometry (each pair's points with that
// pair's geometry; a target matched on both pairs, thermovis-match --band both, comes as two
// entries with one target id, combined by their uncertainties and published with BAND_FUSED).
// Publishes the public contract thermovis/ranges (RangeArray, positions in the left visible
// camera's frame) and the frame's end-to-end stamps on thermovis/timing for the supervisor.
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/perception.h"
#include "thermovis/pipeline/range_stage.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::range_service {

struct RangeConfig {
  pipeline::RangeStageOptions range;
};

struct RangeStats {
  std::uint64_t processed = 0;    // match arrays answered
  std::uint64_t ranged = 0;       // targets with a distance
  std::uint64_t unranged = 0;     // targets without (too few points, at the image edge...)
  std::uint64_t bad = 0;          // match arrays rejected
  std::uint64_t no_geometry = 0;  // match arrays that came before thermovis/geometry
};

// A match array's targets grouped by target id, in the order of their first entries, after the
// checks the whole array must pass before any target is ranged: stamps in pipeline order, known
// bands, a target id at most once per pair, finite points and boxes with an area.
// std::invalid_argument (or node::FrameError) naming the target and field otherwise.
std::vector<std::vector<const TargetMatch*>> checked_targets(const MatchArray& matches);

class RangeNode {
 public:
  RangeNode(transport::Participant& participant, const RangeConfig& config,
            const std::string& service_name);
  void run();  // until node::stop_requested()
  RangeStats stats() const { return stats_; }

 private:
  void answer(const MatchArray& matches);

  RangeConfig config_;
  node::StageOnGeometry<pipeline::RangeStage, pipeline::RangeStageOptions> stage_;
  transport::Reader<MatchArray> matches_in_;
  transport::Writer<RangeArray> ranges_out_;
  transport::Writer<FrameTiming> timing_out_;
  node::HealthReporter health_;
  RangeStats stats_;
};

}  // namespace thermovis::range_service
