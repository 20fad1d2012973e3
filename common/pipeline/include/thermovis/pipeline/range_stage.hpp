#pragma once
// Stage 4: one distance, 3-D position and uncertainty per target from its correspondences.
// Each pair's points are triangulated with that pair's geometry (Eq. 31-33; infrared points from
// the infrared cameras' own centres) and reduced with Eq. 34 and an uncertainty
// (range::range_target); the distance is the target's centre's for known classes (the class's
// shape, range::TargetShape, or a fixed surface-to-centre offset). A target measured on two
// pairs (the match stage's `both`) has its two independent ranges combined by their
// uncertainties (range::combine_ranges) and is reported as Band::fused. Two pairs whose ranges
// disagree beyond their uncertainties (one pair's few points matched a repeated texture a
// period off) are each ranged again about the other's distance: the pair whose points also
// hold a group there is the one that erred (see RangeStage::range).
#include <Eigen/Core>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

#include "thermovis/match/stereo_match.hpp"
#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/range/ranging.hpp"

namespace thermovis::pipeline {

// What one pair's range of a target rests on: its point correspondences (Eq. 34 over the
// points), its whole-region alignment (range::range_region), or both combined by their
// uncertainties (the default).
enum class RangeEstimate { points, region, both };
// "points" | "region" | "both"; std::invalid_argument otherwise.
RangeEstimate parse_range_estimate(const std::string& name);

struct RangeStageOptions {
  // contour_reach_px must be the patch radius the points were matched with (its default is the
  // matcher's default).
  range::RangeOptions range;
  bool surface = false;  // report the distance of the visible surface, not the target's centre
  RangeEstimate estimate = RangeEstimate::both;
  // The pairs' systematic disparity floors, as angles (mrad; on the grid each is this times the
  // grid's px per rad, so a floor stays the cameras' own on any --grid-scale: the infrared
  // camera's pixel is the grid's at scale 0.5 and two of its at 1.0, and the visible cameras are
  // binned to the grid's on the pipeline grid). The whole region's floor
  // (range.region_systematic_disparity_px; the visible region is masked by the infrared
  // silhouette and sees the background's texture around its outline) and the points' floor
  // (range.systematic_disparity_px). 0.13 / 0.06 mrad are 0.11 / 0.05 px of the visible camera
  // (835 px/rad), 0.15 / 0.08 mrad 0.06 / 0.03 px of the infrared's (416 px/rad). Set with
  // `thermovis bench ranging --trials 10 --seed 1|2|3 --mode all --grid-scale 0.5|1.0`, 5-100 m:
  // 64-74 % of each mode's errors within one sigma over all distances, 57-87 % per distance
  // (one distance's 30 trials: +-8.5 %). Before (0.18 / 0.05 grid px / 0.12 / 0.06) the binned
  // visible pair had 81 % on the pipeline grid and the infrared 43 % at 60 m; the visible
  // points' floor in grid px had suited the unbinned pipeline grid.
  double region_floor_visible_mrad = 0.13;
  double region_floor_infrared_mrad = 0.15;
  double points_floor_visible_mrad = 0.06;
  double points_floor_infrared_mrad = 0.08;
};

// One pair's measurement of a target: the box it was matched in (left image of the grid) and
// its correspondences (only those whose left pixel lies in the box are used).
struct TargetEntry {
  Band band = Band::visible;
  std::string label;  // the class: it chooses the shape
  cv::Rect box;
  std::vector<match::Correspondence> points;
  match::RegionDisparity region;  // the whole-region alignment (status empty_region: none)
};

struct RangedTarget {
  range::TargetRange range;   // position_m in the rig frame
  Band band = Band::visible;  // the pair that gave it, Band::fused when two were combined
  // From the left visible camera's centre, in its frame (the public contract's frame).
  double distance_m = range::TargetRange::nan;
  Eigen::Vector3d position_m = Eigen::Vector3d::Constant(range::TargetRange::nan);
  bool ok() const { return range.status == range::RangeStatus::ok && std::isfinite(distance_m); }
};

class RangeStage {
 public:
  RangeStage(const PipelineGeometry& geometry, const RangeStageOptions& options = {});
  // One target's entries: one, or two of different pairs (infrared and another). Throws
  // std::invalid_argument for none, more than two, or two of one pair. Bad points or boxes
  // give a status (range::RangeStatus), never an exception.
  RangedTarget range(const std::vector<TargetEntry>& entries) const;

 private:
  // One pair's range. `hint_m` (finite): the distance from this pair's left camera the target
  // is believed at (the other pair's range); the points are grouped about it, and a region
  // that aligned elsewhere is left out.
  range::TargetRange range_entry(const TargetEntry& entry, double& shared_sigma_m,
                                 double hint_m = range::TargetRange::nan) const;
  const range::RangingGeometry& geometry_of(const TargetEntry& entry) const;
  // Two pairs' ranges of one target combined; `from` says which took part.
  range::TargetRange combine_pairs(const std::vector<TargetEntry>& entries,
                                   range::CombinedFrom& from) const;

  range::RangingGeometry visible_, infrared_;
  double grid_px_per_rad_;
  int infrared_reduction_ = 1;  // PipelineGeometry::infrared_reduction
  Eigen::Isometry3d T_reporting_ref_;
  RangeStageOptions options_;
};

}  // namespace thermovis::pipeline
