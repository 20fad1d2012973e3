#pragma once
// The composed maps of a rig, computed once: for each camera, rectified grid pixel -> raw pixel,
// composing distortion correction (the camera model), epipolar rectification ("limit
// correction", stereo_geometry.hpp) and, for the infrared cameras, registration onto the
// visible eye's grid.
//
// Grids:
//  - visible pair: default_pair_grid of the visible pair; both visible eyes map onto it;
//  - infrared registered: each infrared camera is mapped onto the grid of the visible eye on
//    its side (infrared.left -> visible.left's rectified frame), so fusion sees both bands on one
//    grid. Scene points are taken at registration_distance_m from the visible eye's centre
//    (<= 0: infinity). A point at distance L then lands off its visible position by the parallax
//    of registration_parallax_px (for the paper rig's assumed 60 mm vertical offset, at the
//    centre of the field: 5.0 px on the visible grid at 10 m with registration at infinity,
//    1.0 px at 50 m);
//  - infrared pair: the infrared pair rectified on its own grid (default_pair_grid), for
//    infrared-only stereo.
#include <string>

#include "thermovis/rectify/stereo_geometry.hpp"

namespace thermovis::rectify {

struct RectificationOptions {
  camera::RectifiedProjection projection = camera::RectifiedProjection::equirectangular;
  int visible_width = 0;                 // grid columns; 0 = default_pair_grid's
  int infrared_width = 0;                // same for the infrared pair's own grid
  double registration_distance_m = 0.0;  // infrared onto visible; <= 0 = infinity
};

struct RectifiedPair {
  StereoGeometry geometry;
  cv::Mat left_map, right_map;  // CV_32FC2, grid size, raw pixel (x = column, y = row)
};

struct RigRectification {
  RectifiedPair visible;
  RectifiedPair infrared;  // own grid
  // Infrared cameras on the visible grid of their side (CV_32FC2, visible grid size).
  cv::Mat infrared_left_on_visible, infrared_right_on_visible;
  double registration_distance_m = 0.0;
};

// One pair on `grid` (grid size 0 = default_pair_grid of the pair).
RectifiedPair rectify_pair(const camera::Rig& rig, const camera::StereoPair& pair,
                           const camera::RectifiedIntrinsics& grid);
RectifiedPair rectify_pair(const camera::Rig& rig, const camera::StereoPair& pair,
                           camera::RectifiedProjection projection, int width = 0);

// Every map of the rig (visible pair, infrared pair, infrared registered on visible).
RigRectification rectify_rig(const camera::Rig& rig, const RectificationOptions& options = {});

// Displacement (px on a grid of f px per rad) at the centre of the field of a point at
// distance_m seen by a camera offset by offset_m across the line of sight from the eye the grid
// belongs to, when registration assumes registration_distance_m (<= 0 = infinity):
//   f * |atan(offset / L) - atan(offset / D)|.
// Paper rig, 60 mm vertical offset, visible grid (835.4 px per rad), registration at infinity:
// 10.0 px at 5 m, 5.0 px at 10 m, 2.5 px at 20 m, 1.0 px at 50 m. Toward the sides of the field
// it grows (the offset subtends more of the rotation about the baseline): on the paper rig about
// 1.6 times at 48 deg from the centre, with a column part of up to 0.4 times at the corners.
double registration_parallax_px(double f_px_per_rad, double offset_m, double distance_m,
                                double registration_distance_m);

}  // namespace thermovis::rectify

namespace thermovis::rectify {

// Horizontal field a map keeps, deg: the angle between the raw camera's rays at the source
// positions of the leftmost and rightmost entries of output row `row` that fall inside the raw
// image (the angle between pixel centres). 0 when fewer than two entries fall inside.
double field_kept_deg(const camera::CameraModel& raw, const cv::Mat& map_xy, int row);

}  // namespace thermovis::rectify
