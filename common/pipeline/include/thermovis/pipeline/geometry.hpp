#pragma once
// The rectified geometry every stage of the pipeline works on, as data: one grid that both eyes
// of both bands share, and each pair's rectified frames on it. rectify-fuse makes it from the rig
// and the grid options and publishes it (thermovis/geometry); the stages downstream, the offline
// tools and other applications take it from there instead of rebuilding it, so that no two of
// them can disagree about it.
//
// The infrared pair's images may be the grid reduced by an integer (PipelineGeometry::
// infrared_reduction): on the visible camera's full grid the infrared cameras have half its
// pixels per radian, and rectifying them onto it would only interpolate four grid pixels from
// each of theirs. A reduced image's pixel u' is the grid's (u' + 0.5) k - 0.5; boxes, points and
// disparities leave the stages in grid pixels whatever image they were measured on.
//
// Frames (metres): the rig frame is the reference camera's (camera/rig.hpp). Every rectified
// frame has the visible pair's rotation (x along the visible baseline, y down, z forward;
// rectify/stereo_geometry.hpp); the visible pair's frames are centred on the visible cameras, the
// infrared pair's on the infrared cameras: the infrared images are registered onto the visible
// grid at infinity (pure rotation), so an infrared pixel's ray leaves the infrared camera's
// centre. A point's disparity between the two registered infrared images follows the infrared
// baseline; its right eye is not on the grid's x axis (the paper rig's two baselines differ in
// direction by 11 deg), so its points are triangulated from the true right centre
// (range::RangingGeometry::right_centre_m); the row offset this leaves is a fraction of a pixel
// at the distances of interest and the matcher's row model absorbs it.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/camera/rig.hpp"
#include "thermovis/pipeline/bands.hpp"
#include "thermovis/range/ranging.hpp"

namespace thermovis::pipeline {

std::string band_name(Band band);

struct GridOptions {
  double scale = 0.5;  // of the visible pair's default grid: 0.5 is about the infrared's own
  camera::RectifiedProjection projection = camera::RectifiedProjection::equirectangular;
  // Distance at which the infrared is registered onto the visible, m (<= 0: infinity, which
  // PipelineGeometry::infrared describes exactly; rectify_fuse_stage.hpp).
  double registration_distance_m = 0.0;
  // The integer the infrared pair's images reduce the grid by (k x k grid px to one); 0: the one
  // nearest the grid's px per rad over the infrared cameras' own (their pair's default grid):
  // 1 on the pipeline grid, 2 on the visible camera's full grid.
  int infrared_reduction = 0;
};

// One pair on the grid: its two rectified frames in the rig frame (the same rotation) and the
// names of its cameras.
struct PairGeometry {
  std::string left_camera, right_camera;
  Eigen::Isometry3d T_ref_left_rect = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_ref_right_rect = Eigen::Isometry3d::Identity();
  // The right centre's offset from the left one along the grid's x axis, m (the disparity's
  // baseline; the whole baseline for the visible pair).
  double baseline_m = 0.0;
};

struct PipelineGeometry {
  camera::RectifiedIntrinsics grid;
  PairGeometry visible, infrared;
  // The left visible camera in the rig frame: ranges are reported from its centre, in its frame.
  Eigen::Isometry3d T_ref_reporting = Eigen::Isometry3d::Identity();
  double registration_distance_m = 0.0;  // GridOptions'
  // The infrared pair's images are the grid reduced by this integer (1: on the grid itself).
  int infrared_reduction = 1;

  cv::Size grid_size() const { return {grid.width, grid.height}; }
  // The grid a band's images are on (visible, fused: the grid; infrared: reduced by
  // infrared_reduction), and its size.
  camera::RectifiedIntrinsics image_grid(Band band) const;
  cv::Size image_size(Band band) const;
  // The integer a band's images reduce the grid by.
  int reduction(Band band) const { return band == Band::infrared ? infrared_reduction : 1; }
  // The ranging geometry of a pair's points (fused points: the visible pair's).
  range::RangingGeometry ranging(Band band) const;
  // A digest of every field (FNV-1a over the values): frames carry it, so a reader knows the
  // geometry it holds is the one a frame was made on. Never 0.
  std::uint32_t id() const;
};

// The grid reduced by an integer k: k x k pixels to one, its first k * (size / k) columns and
// rows; pixel centres move as in camera::scaled (cx' = (cx + 0.5) / k - 0.5). Throws
// std::invalid_argument for k < 1.
camera::RectifiedIntrinsics reduce_grid(const camera::RectifiedIntrinsics& grid, int k);
// An image reduced by an integer k as reduce_grid reduces its grid: its first k * (size / k)
// columns and rows, k x k pixels averaged to one (cv::resize INTER_AREA) into `out`.
void reduce_image(const cv::Mat& image, int k, cv::Mat& out);
// A coordinate of an image reduced by k on the grid: (x + 0.5) k - 0.5.
inline double grid_coordinate(double reduced, int k) { return (reduced + 0.5) * k - 0.5; }
// A box of grid pixels on the image reduced by k: every reduced pixel it touches.
cv::Rect reduce_box(const cv::Rect& box, int k);

// Throws std::invalid_argument for a rig without its pairs' cameras or a degenerate pair.
PipelineGeometry make_geometry(const camera::Rig& rig, const GridOptions& options);

// The integer factor that reduces `grid` to about px_per_rad (a stage working on fewer pixels
// than the grid has): lround(f / px_per_rad), at least 1; 1 for px_per_rad 0. Throws
// std::invalid_argument for a negative or non-finite px_per_rad.
int grid_reduction(const camera::RectifiedIntrinsics& grid, double px_per_rad);

// Checks a geometry received from elsewhere (a message, a file): std::invalid_argument naming
// the field for a grid that is empty or larger than `max_size`, a non-finite or non-positive f,
// a non-finite centre or pose, a rotation that is not one (|R^T R - I| > 1e-6), the two pairs
// not sharing one rotation, a baseline that is not positive, or an infrared reduction outside
// 1-8 or leaving an image under 16 px.
void validate(const PipelineGeometry& geometry, cv::Size max_size);

// The largest disparity either pair can show for a target at min_distance_m or further (the
// matcher's search range), px.
double max_disparity(const PipelineGeometry& geometry, double min_distance_m);

// A box of a raw left image of `band`'s pair ([x_min, y_min, x_max, y_max] px of the left visible
// or infrared camera of `rig`) on the grid: the bounding box of its border's rays, rotated into
// the grid's frame (at infinity, as the registration). Empty when none reaches the grid.
cv::Rect raw_box_on_grid(const PipelineGeometry& geometry, const camera::Rig& rig, Band band,
                         double x_min, double y_min, double x_max, double y_max);

// The box of points (the left visible camera's frame, m: the reporting frame) in `band`'s left
// image of the grid: each point projected from that pair's left centre. Empty when none is in
// front of the grid. For a target's known surface points this is its silhouette's box on the
// grid, what a detector on the grid finds; raw_box_on_grid of the raw silhouette's box is wider.
cv::Rect points_box_on_grid(const PipelineGeometry& geometry, Band band,
                            const std::vector<Eigen::Vector3d>& points_m);

}  // namespace thermovis::pipeline
