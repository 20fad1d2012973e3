#pragma once
// Obstacles of any class on the pipeline grid (obstacle::ObstacleDetector: stixels on the
// ground of each rectified pair), and their merge with the targets the target path ranged: a
// ranged person keeps its label and its range, and the stixel obstacles over it are merged into
// it instead of being reported a second time. thermovis-obstacles runs it on thermovis/rectified/*
// and thermovis/ranges; `thermovis bench obstacles` runs the detector on the same grid.
//
// Frames and units: boxes and columns are px of the grid's left image; positions in the
// reporting camera's frame (the left visible camera: thermovis/ranges'), metres; distances
// horizontal (along the ground) from that camera's centre.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "thermovis/obstacle/obstacles.hpp"
#include "thermovis/pipeline/bands.hpp"
#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::pipeline {

struct ObstacleStageOptions {
  // The rig on the vehicle: the reference camera's height above the ground, its pitch and roll
  // (the ground search's prior; the simulated scenes' rig is level at 1.4 m).
  obstacle::GroundPrior mounting;
  obstacle::ObstacleOptions obstacles;
  // The reduced grid's resolution, px per rad: obstacles.reduction is chosen from the grid to
  // come nearest to it (2 on the pipeline grid of 417 px/rad, 4 on the full grid of 835), so
  // that the stage's cost does not grow with --grid-scale. 0: obstacles.reduction as given.
  double reduced_px_per_rad = 208.0;
  bool visible = true;   // search the visible pair
  bool infrared = true;  // search the infrared pair
  // A stixel obstacle is merged into a ranged target when this share of its box lies in the
  // target's box and its distance is the target's within merge_tolerance_m + share.
  double merge_overlap = 0.5;
  double merge_tolerance_m = 1.0;
  double merge_tolerance_share = 0.15;
};

// A target of thermovis/ranges: what the target path measured.
struct RangedTarget3d {
  std::uint32_t target_id = 0;
  std::string label;
  cv::Rect box;                                          // grid, left image, px
  double sigma_m = 0;                                    // of its range
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // its centre, reporting frame
  Band band = Band::visible;
};

// One object in the way, as thermovis/obstacles reports it.
struct ReportedObstacle {
  std::string label = "obstacle";          // or the target's
  std::optional<std::uint32_t> target_id;  // the ranged target it is
  obstacle::Obstacle obstacle;             // box, distance, sigma, position, extent, bands
};

struct ObstacleReport {
  std::vector<ReportedObstacle> obstacles;  // nearest first
  // Per grid column (ObstacleResult::free_space_m), made no farther than a ranged target over
  // the column; NaN where no pair found the ground and no target covers the column.
  std::vector<float> free_space_m;
  // Per grid column: the row where the ground is at that column's free-space distance (the
  // line a display draws); NaN where the free space is, or where that ground is not in view.
  std::vector<float> free_space_row;
  obstacle::GroundPlane ground_reporting;  // the ground used (the prior's when none was found)
};

class ObstacleStage {
 public:
  // Throws std::invalid_argument for neither pair, a prior that is not one or bad options.
  // options().obstacles.reduction is the one used (reduced_px_per_rad applied).
  ObstacleStage(const PipelineGeometry& geometry, const ObstacleStageOptions& options = {});
  const ObstacleStageOptions& options() const { return options_; }
  const obstacle::ObstacleDetector& detector() const { return detector_; }
  bool searches(obstacle::PairBand band) const { return detector_.has(band); }

  // One pair's obstacles (left and right of the grid: CV_8UC1, CV_8UC3 or CV_16UC1 counts).
  // Throws std::invalid_argument for a pair not searched or images of another size or type.
  obstacle::PairObstacles detect_pair(obstacle::PairBand band, const cv::Mat& left,
                                      const cv::Mat& right) const {
    return detector_.detect_pair(band, left, right);
  }
  // The same, the ground searched about the pair's last one (obstacle::GroundTracker: one per
  // pair and stream of captures), which takes this capture's.
  obstacle::PairObstacles detect_pair(obstacle::PairBand band, const cv::Mat& left,
                                      const cv::Mat& right,
                                      obstacle::GroundTracker& tracker) const {
    return detector_.detect_pair(band, left, right, tracker);
  }
  // The pairs' obstacles combined (one or both).
  obstacle::ObstacleResult combine(std::vector<obstacle::PairObstacles> pairs) const {
    return detector_.combine(std::move(pairs));
  }
  // The obstacles merged with the targets ranged on the same capture (none: the obstacles
  // alone). Throws std::invalid_argument for a target with a non-finite position or sigma.
  ObstacleReport report(const obstacle::ObstacleResult& result,
                        const std::vector<RangedTarget3d>& targets) const;

 private:
  PipelineGeometry geometry_;
  ObstacleStageOptions options_;
  obstacle::ObstacleDetector detector_;
  obstacle::GroundPlane prior_reporting_;  // the mounting's ground, reporting frame
  // The visible left rectified frame's axes in the reporting frame (the grid's rays are in it).
  Eigen::Matrix3d R_reporting_rect_ = Eigen::Matrix3d::Identity();
};

}  // namespace thermovis::pipeline
