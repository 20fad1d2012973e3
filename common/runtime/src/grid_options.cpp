#include "thermovis/runtime/grid_options.hpp"

#include <map>

namespace thermovis::runtime {

void add_grid_options(CLI::App& app, pipeline::GridOptions& options) {
  app.add_option("--grid-scale", options.scale,
                 "rectified grid resolution relative to the visible camera's")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 1.0));
  const std::map<std::string, camera::RectifiedProjection> projections{
      {"equirectangular", camera::RectifiedProjection::equirectangular},
      {"cylindrical", camera::RectifiedProjection::cylindrical}};
  app.add_option("--projection", options.projection, "equirectangular | cylindrical")
      ->transform(CLI::CheckedTransformer(projections, CLI::ignore_case));
  app.add_option("--registration-m", options.registration_distance_m,
                 "distance at which infrared is registered onto visible, m (0: infinity)")
      ->capture_default_str();
  app.add_option("--infrared-reduction", options.infrared_reduction,
                 "the infrared pair's images are the grid reduced by this integer (0: to the "
                 "infrared cameras' own resolution, 1: on the grid)")
      ->capture_default_str()
      ->check(CLI::Range(0, 8));
}

}  // namespace thermovis::runtime
