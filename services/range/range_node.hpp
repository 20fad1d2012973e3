#pragma once
// thermovis-range: the last stage. Each target's correspondences (thermovis/matches) are
// triangulated on the pipeline grid (Eq. 31-33; points of the infrared pair from the infrared
// cameras' own centres, node::registered_infrared_geometry) and reduced to one distance with Eq. 34
// and an uncertainty (range::range_target); the distance is moved from the target's visible surface
// to its centre for known classes. A target matched on both pairs (thermovis-match --band both)
// comes as two entries with one target id: their ranges are combined by their uncertainties
// (range::combine_ranges) and published with BAND_FUSED. Publishes the public contract
// thermovis/ranges (RangeArray, positions in the left visible camera's frame) and the frame's
// end-to-end stamps on thermovis/timing for the supervisor.
#include <chrono>
#include <cstdint>
#include <string>

#include "thermovis/node/health.hpp"
#include "thermovis/node/pipeline_grid.hpp"
#include "thermovis/perception.h"
#include "thermovis/range/ranging.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::range_service {

struct RangeConfig {
  node::GridOptions grid;
  range::RangeOptions range;
  bool surface = false;  // report the distance of the visible surface, not the target's centre
};

struct RangeStats {
  std::uint64_t processed = 0;  // match arrays answered
  std::uint64_t ranged = 0;     // targets with a distance
  std::uint64_t unranged = 0;   // targets without (too few points, at the image edge...)
  std::uint64_t bad = 0;        // match arrays rejected
};

class RangeNode {
 public:
  RangeNode(transport::Participant& participant, const camera::Rig& rig, const RangeConfig& config,
            const std::string& service_name);
  void run();  // until node::stop_requested()
  RangeStats stats() const { return stats_; }

 private:
  void answer(const MatchArray& matches);

  RangeConfig config_;
  struct Geometries {
    range::RangingGeometry visible;   // visible and fused points
    range::RangingGeometry infrared;  // points of the registered infrared pair
  };
  static Geometries geometries_of(const camera::Rig& rig, const node::GridOptions& grid);
  Geometries geometry_;
  Eigen::Isometry3d T_camera_ref_;  // rig frame -> left visible camera frame
  transport::Reader<MatchArray> matches_in_;
  transport::Writer<RangeArray> ranges_out_;
  transport::Writer<FrameTiming> timing_out_;
  node::HealthReporter health_;
  RangeStats stats_;
};

}  // namespace thermovis::range_service
