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
// the infrared cameras' offset in the rectified frame (the other components shift rows by a
// fraction of a pixel at the distances of interest).
// `visible` is pipeline_geometry(rig, options) (computed once by the caller: it scans the
// field of both cameras).
rectify::StereoGeometry registered_infrared_geometry(const camera::Rig& rig,
                                                     const rectify::StereoGeometry& visible);

}  // namespace thermovis::node
