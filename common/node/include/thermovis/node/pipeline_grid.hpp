#pragma once
// The rectified grid the pipeline works on, the same in every service that reads grid frames:
// the visible pair's default grid (rectify::default_pair_grid, the left camera's centre
// resolution over both eyes' field) resampled by `scale`. Both bands of an eye are on it (the
// infrared registered at `registration_distance_m`).
#include <CLI/CLI.hpp>

#include "thermovis/rectify/stereo_geometry.hpp"

namespace thermovis::node {

struct GridOptions {
  double scale = 0.5;  // of the default grid: 0.5 is about the infrared's own resolution
  camera::RectifiedProjection projection = camera::RectifiedProjection::equirectangular;
  double registration_distance_m = 0.0;  // infrared onto visible; <= 0 = infinity
};

// Adds --grid-scale, --projection and --registration-m.
void add_grid_options(CLI::App& app, GridOptions& options);

rectify::StereoGeometry pipeline_geometry(const camera::Rig& rig, const GridOptions& options);

// The infrared pair as it appears on the pipeline grid (each infrared camera registered at
// infinity onto its eye's visible camera): the same grid and rotation, the infrared cameras'
// own centres. A point's disparity between the two registered infrared images follows the
// infrared baseline, so ranging on them uses this geometry: baseline_m is the x component of
// the infrared cameras' offset in the rectified frame. The other components matter for
// ranging (the paper rig's right infrared eye is 68 mm off the grid's axis: triangulating with
// the x component alone was off by up to 4 % at 25 m), so the range service triangulates from
// the true right centre (T_ref_right_rect; range::RangingGeometry::right_centre_m); they shift
// rows by a fraction of a pixel at the distances of interest, which the matcher's row model
// absorbs.
// `visible` is pipeline_geometry(rig, options) (computed once by the caller: it scans the
// field of both cameras).
rectify::StereoGeometry registered_infrared_geometry(const camera::Rig& rig,
                                                     const rectify::StereoGeometry& visible);

}  // namespace thermovis::node
