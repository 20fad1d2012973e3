#pragma once
// Which simulated target a measured range belongs to: the one whose centre is nearest to the
// range's line of sight, within kOffsetM + kOffsetPerM * its distance (a detector's box need not
// be centred on the target). Directions and positions in the left visible camera's frame (the
// frame of thermovis/ranges and of sim::TargetTruth::position_m).
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::cli {

inline constexpr double kTruthMatchOffsetM = 0.8;
inline constexpr double kTruthMatchOffsetPerM = 0.02;

inline std::optional<sim::TargetTruth> truth_on_line_of_sight(
    const std::vector<sim::TargetTruth>& truths, const Eigen::Vector3d& position_m) {
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
  if (best == nullptr) return std::nullopt;
  return *best;
}

}  // namespace thermovis::cli
