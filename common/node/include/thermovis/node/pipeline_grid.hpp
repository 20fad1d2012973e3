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

}  // namespace thermovis::node
