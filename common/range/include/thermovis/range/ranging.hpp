#pragma once
// Ranging of targets from stereo correspondences on a rectified grid (the paper's Section 2.4).
//
// Frames: the left rectified frame (rectify/stereo_geometry.hpp) has its origin at the left
// camera centre, x along the baseline towards the right camera, y down, z forward; the right
// rectified frame is the same rotation at the right camera centre (baseline_m along x). Both eyes
// share one rectified grid, so a row is an epipolar plane (angle beta about the baseline) and a
// column gives alpha, the angle of a ray out of the plane perpendicular to the baseline.
//
// Triangulation (Eq. 31-33): theta = pi/2 - alpha for each eye; in the epipolar plane the
// triangle (left centre, right centre, target) has angle theta_L at the left centre, pi - theta_R
// at the right one and theta_R - theta_L = alpha_L - alpha_R at the target, so by the sine rule
// the distance from the left centre is B = A sin(theta_R) / sin(theta_R - theta_L)
//                                      = A cos(alpha_R) / sin(alpha_L - alpha_R),
// and the depth (Eq. 33) is B sin(theta_L) cos(beta) = B cos(alpha_L) cos(beta). No pinhole
// approximation: valid over the whole wide field of the grid (equirectangular or cylindrical).
//
// Per target (Eq. 34): gross outliers (beyond median +- 5 scaled median absolute deviations: far
// background, points near infinity, which would drag the mean) are dropped first; then the
// per-point distances d_i are kept within mean +- mean absolute deviation (Eq. 34, one pass as in
// the paper), and the target distance is the mean of the kept points.
//
// Uncertainty: Eq. 2 (dL = L^2 dc / (f d)) is the pinhole form of the derivative dB/d(disparity)
// used here on the angular grid. The disparity noise is measured from the points themselves by
// bootstrapping the whole Eq. 34 estimator over the target's points (so the rejection's effect
// is included), scaled by a small-sample Student factor, and combined with a floor for the
// systematic sub-pixel error (rectification/calibration residual, px) that averaging cannot
// remove.
#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/match/region_align.hpp"
#include "thermovis/match/stereo_match.hpp"

namespace thermovis::range {

struct RangingGeometry {
  camera::RectifiedCamera grid;  // the rectified grid both eyes share
  double baseline_m = 0.0;       // distance between the two camera centres (A of Eq. 32)
  // Left rectified frame in the rig frame (the reference camera's frame, metres), used to report
  // positions; identity reports them in the left rectified frame.
  Eigen::Isometry3d T_ref_left_rect = Eigen::Isometry3d::Identity();
  // The right camera's centre in the left rectified frame when it is off that frame's x axis: a
  // pair shown on another pair's grid (the pipeline's infrared pair on the visible grid: the
  // paper rig's two baselines differ in direction by 11 deg, which puts the right infrared eye
  // 68 mm off the visible grid's axis). Zero: at (baseline_m, 0, 0), the rectified case of
  // Eq. 31-33.
  Eigen::Vector3d right_centre_m = Eigen::Vector3d::Zero();
};

struct PointTriangulation {
  bool valid = false;
  double alpha_left = 0, alpha_right = 0, beta = 0;  // rad
  double distance_m = 0;                             // B of Eq. 32: from the left camera centre
  double depth_m = 0;                                // Eq. 33: along the rectified z axis
  Eigen::Vector3d position_left_rect = Eigen::Vector3d::Zero();  // m
  double distance_per_px = 0;  // |dB / d disparity|, m per px (Eq. 2 on the angular grid)
};

// One correspondence: left pixel (column, row) and disparity (px, left column - right column).
// Invalid when the disparity is not positive (target at or beyond infinity), a ray leaves the
// grid's domain, or the input is not finite.
PointTriangulation triangulate(const camera::RectifiedCamera& grid, double baseline_m,
                               const Eigen::Vector2d& left_px, double disparity_px);

// The same for a right camera centred at `right_centre` (left rectified frame, any direction):
// the point on the left pixel's ray that the right eye sees at the column of left x - disparity
// (its angle out of the y-z plane, alpha = asin(x / |r|), measured from the right centre).
// With right_centre = (A, 0, 0) it is the rectified case above.
PointTriangulation triangulate(const camera::RectifiedCamera& grid,
                               const Eigen::Vector3d& right_centre, const Eigen::Vector2d& left_px,
                               double disparity_px);

// Its core: the distance along the left eye's unit ray `u` (left rectified frame) of the point
// that a right eye centred at `right_centre` sees at the angle whose sine is `sin_alpha_right`
// (its column's alpha); NaN when there is none in front.
double distance_on_left_ray(const Eigen::Vector3d& u, const Eigen::Vector3d& right_centre,
                            double sin_alpha_right);

// The triangulation the geometry calls for (right_centre_m zero: the rectified one).
PointTriangulation triangulate(const RangingGeometry& geometry, const Eigen::Vector2d& left_px,
                               double disparity_px);

// The line-of-sight offset from a target's visible surface to its centre for a class (m), from
// the simulated shapes' default geometry: person 0.118 (elliptic torso 0.3 m deep: 0.15 pi / 4),
// pole 0.079 (0.2 m cylinder), marker 0.033 (0.1 m sphere); 0 for other classes (a car's depends
// on its heading). Used where no TargetShape moves each point to the centre.
double surface_to_centre_m(const std::string& target_class);

// The inverse: where a point of the left rectified frame appears (left pixel and disparity).
// False when it is not in front of both eyes' grids.
bool project_point(const camera::RectifiedCamera& grid, double baseline_m,
                   const Eigen::Vector3d& position_left_rect, Eigen::Vector2d& left_px,
                   double& disparity_px);
// The same for the geometry's pair, its right eye where right_centre_m says (off the grid's axis
// included): the inverse of triangulate(geometry, ...).
bool project_point(const RangingGeometry& geometry, const Eigen::Vector3d& position_left_rect,
                   Eigen::Vector2d& left_px, double& disparity_px);

enum class RangeStatus {
  ok,
  empty_box,             // the box has no area
  box_outside_image,     // the box does not overlap the image
  target_at_image_edge,  // no usable points and the box touches the image edge (the other eye
                         // or the correlation patch cannot see the target there)
  no_matches,            // no correspondence in the box
  too_few_points,        // fewer than min_points valid points after the rejection
  no_region,             // the whole-region alignment gave no disparity (its message says why)
};
std::string status_name(RangeStatus status);

// The shape of an upright target about its vertical axis, to range its centre (the point on the
// axis at half its height) rather than its visible surface. Horizontal cross-sections are
// ellipses (spheres for heads) stacked over the height, in fractions of the height from the
// bottom. A point at lateral offset x from the axis (across the line of sight) on a section of
// half-width a and half-depth b lies b sqrt(1 - (x/a)^2) in front of the axis: surface points
// near the middle about b, points on the occluding contour (the silhouette, where infrared and
// fused features concentrate) at the axis depth. An empty shape ranges the surface.
struct TargetShape {
  struct Section {
    double from = 0, to = 0;  // height fractions (0 = bottom, 1 = top)
    double half_width_m = 0;  // across the line of sight (sphere: its radius)
    double half_depth_m = 0;  // along the line of sight
    bool sphere = false;      // a sphere centred at mid-section (the head)
  };
  std::vector<Section> sections;
  bool empty() const { return sections.empty(); }
  // The default shapes of the simulated targets: person (legs 0.4 x 0.27 m, torso 0.5 x 0.3 m,
  // neck, head of radius 0.1225 m, 1.75 m tall), pole (0.2 m cylinder), marker (0.1 m sphere);
  // empty for other classes.
  static TargetShape for_class(const std::string& target_class);
};

struct RangeOptions {
  int min_points = 3;  // kept points needed for a distance
  // Floor of the disparity error that averaging keeps, px (sub-pixel interpolation's own bias,
  // what remains of the contour effect below). With contour_reach_px and shape_sigma_m below,
  // 0.05 px puts 65-76 % of the errors within one sigma (`thermovis bench ranging --trials 8
  // --mode all --json`, seeds 7, 11 and 13 pooled, about 145 targets per mode).
  double systematic_disparity_px = 0.05;
  int bootstrap_samples = 100;   // resamples for the uncertainty
  int edge_margin_px = 5;        // a box this close to the image border is at the edge
  int max_rejection_passes = 1;  // Eq. 34 passes (1 = the paper's)
  // How far apart two points of one target may range (reject_outliers_eq34's windows): the
  // larger of this share of the distance (a person's depth at 5 m) and this many pixels of
  // disparity noise (far targets). Both 0: no nearest-group screen.
  double group_relative = 0.06;
  double group_disparity_px = 0.5;
  // A distance the target is known to lie near, m (its whole-region range: pipeline::RangeStage
  // sets it when the region aligned), NaN for none. With it the group screen keeps the densest
  // group within two windows of this distance instead of the nearest dense one, and the points
  // give no range when no group of 3 lies there: a few points matched to the wrong period of a
  // repeated texture (a striped shirt) form a nearer group of 30 % of a small box's points and
  // ranged a 25 m person at 16.6 m, 702 pixels of its region aligning at the right disparity.
  double group_hint_m = std::numeric_limits<double>::quiet_NaN();
  // Non-empty: each point's distance is moved to the target's centre by the shape (see
  // TargetShape) before Eq. 34, and the centre is reported. The vertical is the rig frame's +y
  // (T_ref_left_rect: the rig is level).
  TargetShape shape;
  // With a shape: how far from its centre a point's correlation patch reaches, px (the matcher's
  // patch radius, match::MatchOptions::patch_radius, whose default this follows; the tools set
  // the radius they matched with). A point whose patch holds the target's
  // occluding contour is ranged at the contour's depth (the axis), not at its centre's surface:
  // the contour is the patch's strongest edge and the same in both eyes. Without this, points
  // inside the silhouette's edge were moved too far back (+0.03 m at 5 m, +0.04 m at 10 m).
  double contour_reach_px = match::MatchOptions{}.patch_radius;
  // One-sigma error of the shape's centre (build, heading, pose of the real target against the
  // model), m; added to the uncertainty when a shape is used. On the simulated people (the
  // model's own shape, any heading) the fused error at 5-10 m is 0.01-0.02 m in all.
  double shape_sigma_m = 0.015;
  // One-sigma error of a whole-region range's model (range_region), m: one translation for the
  // whole target ignores its depth (a person's 0.3 m spread the region's disparity by 1.7 px at
  // 5 m on the pipeline grid), and the mix of outline and inside is only estimated. On the
  // simulated people the region's range is 0.05-0.07 m too far at 5 m and within 0.03 m at
  // 10-20 m (`thermovis bench ranging --estimate region`).
  double region_model_sigma_m = 0.05;
  // Floor of a whole-region disparity's error, px (range_region): the outline's mixed pixels
  // and the background around it pull the region's disparity by a few hundredths of a pixel
  // where the background behind is plain, more where it is textured.
  double region_systematic_disparity_px = 0.05;
};

// How far a point of a target at `distance_m` may range from another of it (reject_outliers_eq34's
// window): the larger of options.group_relative of the distance and options.group_disparity_px
// of disparity, `m_per_px` metres each.
double group_window_m(const RangeOptions& options, double distance_m, double m_per_px);

struct TargetRange {
  RangeStatus status = RangeStatus::no_matches;
  std::string message;  // why there is no distance (empty when ok)
  static constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  double distance_m = nan;          // from the left camera centre, mean of the kept points
  double depth_m = nan;             // Eq. 33, mean of the kept points
  double sigma_m = nan;             // one-sigma uncertainty of distance_m
  double disparity_px = nan;        // mean disparity of the kept points
  double disparity_sigma_px = nan;  // sigma_m expressed as disparity
  Eigen::Vector3d position_m = Eigen::Vector3d::Constant(nan);  // rig frame (T_ref_left_rect)
  int points_total = 0;                                         // correspondences given
  int points_valid = 0;                                         // of which triangulated
  int points_used = 0;                                          // kept by Eq. 34
  int region_pixels = 0;  // pixels of a whole-region alignment the range rests on (0: none)
  std::vector<int> used;  // indices (into the matches given) of the points kept
  bool at_image_edge = false;
};

// Ranges one target: `box` in the left rectified image, `matches` the correspondences found in
// it (only those whose left pixel lies in the box are used). Never throws on bad data: the status
// and message say why there is no distance.
TargetRange range_target(const RangingGeometry& geometry, const cv::Rect& box,
                         const std::vector<match::Correspondence>& matches,
                         const RangeOptions& options = {});

// Ranges one target from its whole-region disparity (match::align_region): the region's anchor
// pixel triangulated at the region's disparity. The region's alignment follows its strongest
// gradients: the outline, where the silhouette is at the depth of the target's axis, and the
// inside's texture, on the visible surface. So the range is moved `surface_to_centre_m` (the
// class's surface-to-centre offset, surface_to_centre_m) times the inside's share of the
// alignment (1 - contour_fraction) further along the line of sight. Uncertainty: the region's
// own sigma and options.region_systematic_disparity_px in quadrature, scaled by Eq. 2, and
// options.region_model_sigma_m. Never throws on bad data: a region without
// a disparity gives RangeStatus::no_region with its message.
TargetRange range_region(const RangingGeometry& geometry, const cv::Rect& box,
                         const match::RegionDisparity& region, double surface_to_centre_m,
                         const RangeOptions& options = {});

// The largest disparity a target at min_distance_m or further can have on the grid (the matcher's
// search range), with 2 px of margin.
double max_disparity_for(const RangingGeometry& geometry, double min_distance_m);

// Moves a range from the target's visible surface `offset_m` further along the line of sight
// (to the target's centre); does nothing to a range without a distance.
void move_to_centre(TargetRange& range, const RangingGeometry& geometry, double offset_m);

// Two ranges of one target (the visible and the infrared pair: other cameras, other noise; or
// one pair's points and its whole-region alignment) combined by inverse variance.
// `shared_sigma_m` is the part of both uncertainties that is one error, not two (the target
// shape's centre: the same person; one pair's systematic floor), so it is taken out before
// the weights and added back whole. The result's distance, depth and disparity are those of its
// position seen from `report`'s left camera; `used` is empty (the points belong to two pairs).
// When one range failed (or has no finite sigma) the other is returned, re-expressed the same
// way; when both failed, `a`'s status with both messages. `from` (optional) says which.
enum class CombinedFrom { neither, a, b, both };
TargetRange combine_ranges(const TargetRange& a, const TargetRange& b,
                           const RangingGeometry& report, double shared_sigma_m,
                           CombinedFrom* from = nullptr);

// The gross-outlier screen then Eq. 34 (max_passes passes): the indices of the kept values.
// `windows` (optional, one per value, in the values' unit) is how far a value of the target
// itself may lie from another: with them the screen first keeps the nearest dense group, anchored
// by the smallest value that has at least 30 % of all values (and 3) within its window, and
// made of the values within two windows of that group's mode; Eq. 34 then trims it, but not
// below 3 values. Without them, or with no such value, the gap-and-median screen alone. With
// windows and a finite `hint` (RangeOptions::group_hint_m) the group is anchored by the value
// within two of its windows of the hint that has the most values (and 3) within its window, and
// none is kept when there is no such value.
std::vector<int> reject_outliers_eq34(const std::vector<double>& values, int max_passes,
                                      const std::vector<double>& windows = {},
                                      double hint = std::numeric_limits<double>::quiet_NaN());

// reject_outliers_eq34 without windows, then the mean of the values it keeps, of many resamples
// (with replacement) of one set of values: the estimator whose spread is range_target's
// bootstrap uncertainty. The values are sorted once and each resample is put in order by
// counting its picks' ranks, so a resample costs no sort and no allocation; the estimate equals
// mean_of(sample, reject_outliers_eq34(sample, max_passes)) bit for bit.
class Eq34Resampler {
 public:
  Eq34Resampler(std::vector<double> values, int max_passes);
  ~Eq34Resampler();
  Eq34Resampler(const Eq34Resampler&) = delete;
  Eq34Resampler& operator=(const Eq34Resampler&) = delete;
  // The resample values[picks[0]], values[picks[1]], ...; NaN for no picks. Throws
  // std::out_of_range for a pick outside the values.
  double estimate(const std::vector<size_t>& picks);

 private:
  struct Buffers;
  std::vector<double> values_;
  int max_passes_;
  std::vector<int> order_;  // indices of values_ in ascending order of value
  std::vector<int> rank_;   // position of each value in order_
  std::vector<int> counts_;
  std::vector<double> sample_;
  std::unique_ptr<Buffers> buffers_;
};

}  // namespace thermovis::range
