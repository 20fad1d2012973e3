#pragma once
// The ground under the rig on the wide rectified grid, found in the v-disparity of a dense
// disparity map with the rig's mounting (camera height, pitch, roll) as the prior.
//
// Frames: a pair's left rectified frame (rectify/stereo_geometry.hpp: x along the baseline, y
// down, z forward, origin at the left camera centre, metres). The ground is the plane
// n . p = h there: n the unit normal pointing down (gravity), h the origin's height above it.
//
// Why not the pinhole v-disparity: on the wide grid a row is an epipolar plane (the rotation
// beta about the baseline) and a column the angle alpha out of the plane perpendicular to the
// baseline (camera/rectified.hpp). A point is P = rho (tan alpha, sin beta, cos beta), rho its
// distance from the baseline's axis, and on the plane n . P = h
//     1 / rho = w_x tan(alpha) + w_y sin(beta) + w_z cos(beta),    w = n / h,
// exactly, for either projection and any right eye (rho comes from the triangulated point). So
// the ground is not a line of disparity against row: along a row its equirectangular disparity
// falls roughly as cos^2(alpha), and a baseline that is not level (w_x; the paper rig's visible
// baseline is 1.7 deg off) adds a term that grows as tan(alpha). The v-disparity here
// histograms, per row, the row disparity
//     v = f A (1 / rho - w_x tan(alpha))      px (A the baseline, f the grid's px per rad)
// which on the ground is f A |w_yz| sin(beta + phi): one value per row, the pinhole
// v-disparity's line bent into a sine. The prior's w_x is kept for the histogram; the search
// moves phi (the pitch) and |w_yz| (the height); a least-squares fit of all three components of
// w on the ground's pixels then refines it.
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

namespace thermovis::obstacle {

// How the rig sits on the vehicle: the prior of the ground.
struct GroundPrior {
  double camera_height_m = 1.4;  // the rig frame's origin (reference camera) above the ground
  double pitch_rad = 0.0;        // optical axis below the horizontal (looking down) > 0
  double roll_rad = 0.0;         // the rig's x axis below the horizontal (right side down) > 0
};

// A plane n . p = height_m in some frame: n unit, pointing down; height_m the origin's height.
struct GroundPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  double height_m = 0.0;
  // Height of a point above the plane, m (negative below it).
  double height_of(const Eigen::Vector3d& p) const { return height_m - normal.dot(p); }
};

// The prior's plane in the rig frame: gravity (sin roll cos pitch, cos roll cos pitch,
// sin pitch). Throws std::invalid_argument for a height that is not > 0 or angles that are not
// finite.
GroundPlane prior_plane(const GroundPrior& prior);
// A plane given in frame a, in frame b: T_a_b takes b's points into a.
GroundPlane plane_in_frame(const GroundPlane& plane_a, const Eigen::Isometry3d& T_a_b);
// Pitch and roll of a plane in the rig frame (the inverse of prior_plane), rad.
double pitch_of(const GroundPlane& rig_plane);
double roll_of(const GroundPlane& rig_plane);

enum class GroundStatus {
  ok,
  no_disparity,  // too few pixels with a disparity: sky, fog, a featureless or covered view
  no_ground,     // no ground near the prior: a wall filling the view, the rig tilted, no road
};
std::string status_name(GroundStatus status);

struct GroundOptions {
  // Search about the prior: pitch +- max_pitch_change_rad, height within this factor either way.
  double max_pitch_change_rad = 0.07;  // 4 deg
  double max_height_factor = 1.15;
  double pitch_step_rad = 0.005;  // the least-squares fit refines within a step
  int height_steps = 12;          // over the height factor's range, log-spaced
  double bin_px = 0.5;            // v-disparity bin
  double tolerance_px = 0.6;      // a pixel on the ground: |v - v_ground| < this + share * v
  double tolerance_share = 0.05;
  double min_ground_v_px = 0.8;   // rows whose ground is farther (smaller v) are not searched
  double min_valid_share = 0.05;  // of the pixels: fewer with a disparity -> no_disparity
  double min_row_share = 0.35;    // of the searched rows holding ground: fewer -> no_ground
  int min_row_pixels = 4;         // pixels on the ground that make a row hold it
  // Of the valid pixels in the searched rows. On a real road (MS2 frame 000011, both pairs)
  // 25-38 % of them lie on the ground, where hedges, trees and cars fill much of the lower half;
  // 0.4 rejected it. The simulated street and obstacles scenes give the same obstacles at 0.2
  // as at 0.4 (`thermovis bench obstacles`).
  double min_inlier_share = 0.2;
  int column_step = 4;  // the fit reads every column_step-th column (the ground spans hundreds)
  // Least-squares fits on the pixels near the plane, each on the last one's, at most (fewer
  // where it moves by less than 1e-4 of itself). Two leave the street's ground 2 cm high and
  // 0.4 deg pitched up against the empty road's, held by the feet of its walls and targets;
  // about eight settle it there, for recall to 40 m 93.4 % against 95.1 % on the street (its
  // crossing person merged with the one standing in front of it or the hedge behind) and
  // 66 % against 60 % on the obstacles scene (docs/obstacles.md).
  int max_refits = 2;
};

struct GroundFit {
  GroundStatus status = GroundStatus::no_disparity;
  std::string message;  // why not ok
  GroundPlane plane;    // the pair's left rectified frame (the prior's when not ok)
  int valid_pixels = 0, inlier_pixels = 0;
  int rows_searched = 0, rows_with_ground = 0;
  bool ok() const { return status == GroundStatus::ok; }
};

// Fits the ground to `points` (CV_32FC3: each pixel's triangulated point in the left rectified
// frame, m; NaN where it has no disparity) of a grid whose rows are at `row_beta` (rad, one per
// row), disparities scaled by `f_baseline_px_m` (f A, px m: the grid's px per rad times the
// baseline); it reads every options.column_step-th column. `prior` is in the same frame.
// Throws std::invalid_argument for a points image of another type or a row_beta of another
// length.
GroundFit fit_ground(const cv::Mat& points, const std::vector<double>& row_beta,
                     double f_baseline_px_m, const GroundPlane& prior,
                     const GroundOptions& options = {});

// Whether a plane is within the search fit_ground makes about `prior` with `options` (its
// pitch within 1.5 max_pitch_change_rad, its height within 1.1 max_height_factor either way,
// its normal's x within 0.1): what fit_ground accepts.
bool within_search(const GroundPlane& plane, const GroundPlane& prior,
                   const GroundOptions& options);

struct GroundTrackerOptions {
  // The search about the last frame's ground: pitch +- this, height within this factor. A
  // vehicle's pitch moves a degree or two on braking and bumps, its height a few centimetres.
  double max_pitch_change_rad = 0.026;  // 1.5 deg
  double max_height_factor = 1.05;
};

// The ground from frame to frame, for one pair (its left rectified frame): after a frame whose
// ground was found, the next frame's search is about that ground and narrower (a wall or a
// hedge near the prior's edge cannot win it, and it costs less); after a frame without one,
// the search is the prior's again. ObstacleDetector::detect with GroundTracks uses one per
// pair, and where the narrow search finds no ground, or one beyond the prior's search, searches
// about the prior in the same frame.
class GroundTracker {
 public:
  // Throws std::invalid_argument for a pitch change not > 0 or a height factor not > 1.
  explicit GroundTracker(const GroundTrackerOptions& options = {});
  const GroundTrackerOptions& options() const { return options_; }
  bool tracking() const { return last_.has_value(); }
  // The plane to search about: the last ground found, or `prior` when there is none.
  const GroundPlane& centre(const GroundPlane& prior) const { return last_ ? *last_ : prior; }
  // The prior's options, their pitch and height ranges narrowed when tracking.
  GroundOptions search_options(const GroundOptions& prior_options) const;
  // This frame's fit: its plane is the next centre when ok; otherwise the prior's again.
  void update(const GroundFit& fit);
  void reset() { last_.reset(); }

 private:
  GroundTrackerOptions options_;
  std::optional<GroundPlane> last_;
};

}  // namespace thermovis::obstacle
