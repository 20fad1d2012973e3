#pragma once
// Which simulated target a measured range belongs to: the one whose centre is nearest to the
// range's line of sight, within kOffsetM + kOffsetPerM * its distance (a detector's box need not
// be centred on the target). Directions and positions in the left visible camera's frame (the
// frame of thermovis/ranges and of sim::TargetTruth::position_m).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::cli {

inline constexpr double kTruthMatchOffsetM = 0.8;
inline constexpr double kTruthMatchOffsetPerM = 0.02;

// What a measurement is checked against: the target's name, centre and distance. Not its
// surface points, thousands of them: copying those for every range and obstacle made the
// measuring process itself cost the pipeline's two cores about a tenth of their time.
struct TruthSummary {
  std::string id;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // left visible camera's frame, m
  double distance_m = 0.0;
};
inline TruthSummary summary_of(const sim::TargetTruth& t) {
  return {t.id, t.position_m, t.distance_m};
}

// The target of `truths` a range at `position_m` belongs to, nullptr for none.
inline const sim::TargetTruth* truth_on_line_of_sight(const std::vector<sim::TargetTruth>& truths,
                                                      const Eigen::Vector3d& position_m) {
  const Eigen::Vector3d direction = position_m.normalized();
  const sim::TargetTruth* best = nullptr;
  double best_offset_m = 0.0;
  for (const sim::TargetTruth& t : truths) {
    // How far the target's centre is from the line of sight the range was measured along.
    const double along = t.position_m.dot(direction);
    const double offset_m = (t.position_m - along * direction).norm();
    if (along > 0 && offset_m < kTruthMatchOffsetM + kTruthMatchOffsetPerM * t.distance_m &&
        (best == nullptr || offset_m < best_offset_m)) {
      best = &t;
      best_offset_m = offset_m;
    }
  }
  return best;
}

}  // namespace thermovis::cli
