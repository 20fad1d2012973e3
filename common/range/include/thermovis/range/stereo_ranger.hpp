#pragma once
// Ranging of targets in the raw frames of the dual-band rig: rectification of both pairs (once
// computed composed maps), infrared AGC, matching inside each target's box on one pair or both,
// and ranging (ranging.hpp).
//
// Modes:
//  - visible: the visible pair on its rectified grid, matched on the grey image;
//  - infrared: the infrared pair on its own rectified grid, 16-bit counts through the AGC;
//  - fused: both pairs range the target (the infrared one on the visible box seen from the left
//    infrared camera at the target's distance) and the two independent measurements are
//    combined by their uncertainties (combine_ranges): by day the visible pair's finer grid
//    weighs most, at night the infrared pair gives the range alone. Matching on fused images
//    (each eye's visible image blended with its infrared camera registered at the target's
//    distance, the paper's way) was measured against it and ranged worse beyond 10 m: the
//    infrared content, at half the resolution, added its own matching noise to the visible
//    texture (60 m: 2.36 m mean error against 0.52 m; README, "Matching and ranging").
// Boxes are given in the rectified left image of the mode's grid (the visible grid for visible
// and fused, the infrared grid for infrared); raw_box_to_rectified converts a raw box.
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>

#include "thermovis/camera/rig.hpp"
#include "thermovis/match/stereo_match.hpp"
#include "thermovis/range/ranging.hpp"

namespace thermovis::range {

// A box of a raw image of `raw` ([x_min, y_min, x_max, y_max] px) on the rectified `grid` whose
// frame is T_ref_rect: the bounding box of its border's rays (empty when none reaches the grid).
cv::Rect raw_box_on_grid(const camera::RigCamera& raw, const Eigen::Isometry3d& T_ref_rect,
                         const camera::RectifiedCamera& grid, double x_min, double y_min,
                         double x_max, double y_max);

enum class Mode { visible, infrared, fused };
std::string mode_name(Mode mode);
// "visible" | "infrared" | "fused"; throws std::invalid_argument.
Mode parse_mode(const std::string& name);

// Raw images as the cameras deliver them: visible CV_8UC3 (BGR) or CV_8UC1, infrared CV_16UC1
// counts or CV_8UC1. Sizes must be the rig cameras'.
struct RawFrames {
  cv::Mat visible_left, visible_right, infrared_left, infrared_right;
};

// The frames on the rectified grids (CV_8UC1).
struct RectifiedFrames {
  cv::Mat visible_left, visible_right;    // visible grid
  cv::Mat infrared_left, infrared_right;  // infrared grid, after the AGC
  cv::Mat infrared_counts_left;  // infrared grid, raw counts (CV_16UC1; for warm-blob detection)
};

struct RangerOptions {
  match::MatchOptions match;  // method, patch, thresholds; the disparity range is set here
  RangeOptions range;
  double min_distance_m = 2.5;  // nearest target searched (sets the maximum disparity)
  // Distance from the target's visible surface to the point the distance is reported for, along
  // the line of sight, m (0 = the surface). For a person (elliptic torso 0.3 m deep) the mean
  // offset of the visible half to the centre is 0.15 m * pi / 4 = 0.118 m. Used only when
  // range.shape is empty (a shape moves each point to the centre by its own position).
  double centre_offset_m = 0.0;
};

struct RangedTarget {
  TargetRange range;
  Mode mode = Mode::visible;
  cv::Rect box;                 // rectified box used (left image of the mode's grid)
  match::MatchResult matching;  // counts of the matching stage
  // Fused: each pair's own range (visible on the box; infrared on `infrared_box`, the box seen
  // from the left infrared camera at the target's distance); `range` is their combination and
  // `matching` the visible pair's.
  TargetRange visible, infrared;
  cv::Rect infrared_box;
  match::MatchResult infrared_matching;
};

// The line-of-sight offset from a target's visible surface to its centre for a class (m), from
// the simulated shapes' default geometry: person 0.118 (elliptic torso 0.3 m deep: 0.15 pi / 4),
// pole 0.079 (0.2 m cylinder), marker 0.033 (0.1 m sphere); 0 for other classes (a car's depends
// on its heading).
double surface_to_centre_m(const std::string& target_class);

class StereoRanger {
 public:
  // Computes the rig's rectification maps (visible pair, infrared pair). Throws for a rig
  // without the cameras its pairs name.
  explicit StereoRanger(const camera::Rig& rig);
  ~StereoRanger();
  StereoRanger(StereoRanger&&) noexcept;
  StereoRanger& operator=(StereoRanger&&) noexcept;

  // Rectifies and AGCs one frame set. Throws std::invalid_argument naming a missing image or
  // a wrong size/type.
  RectifiedFrames rectify(const RawFrames& raw) const;

  // Ranges one target. Never throws for bad boxes or missing matches (see TargetRange.status).
  RangedTarget range(const RectifiedFrames& frames, Mode mode, const cv::Rect& box,
                     const RangerOptions& options) const;

  // A box of a raw left image (visible.left or infrared.left, [x_min, y_min, x_max, y_max] px)
  // to the mode's rectified left grid: the bounding box of its border's rays.
  cv::Rect raw_box_to_rectified(Mode mode, double x_min, double y_min, double x_max,
                                double y_max) const;

  // A box of the infrared left rectified grid on the visible left rectified grid (rays at
  // infinity: the infrared camera's offset shifts a target at L by offset / L rad).
  // With distance_m > 0, the box of a target at that distance from the left camera of `box`'s
  // grid (the cameras' offset taken into account).
  cv::Rect infrared_box_to_visible(const cv::Rect& box, double distance_m = 0.0) const;
  // The reverse: a box of the visible left rectified grid on the infrared one.
  cv::Rect visible_box_to_infrared(const cv::Rect& box, double distance_m = 0.0) const;

  const RangingGeometry& geometry(Mode mode) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace thermovis::range
