#pragma once
// The grid options of thermovis-rectify-fuse (and of the tools that make a pipeline geometry
// from a rig): the services downstream take the geometry from thermovis/geometry instead.
#include <CLI/CLI.hpp>

#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::runtime {

// Adds --grid-scale, --projection and --registration-m.
void add_grid_options(CLI::App& app, pipeline::GridOptions& options);

}  // namespace thermovis::runtime
