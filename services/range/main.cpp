// thermovis-range: distances, positions and uncertainties of the matched targets.
#include <CLI/CLI.hpp>
#include <iostream>

#include "range_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-range", "ranges of the matched targets on thermovis/ranges",
                       /*with_rig=*/false);
  range_service::RangeConfig config;
  app.add_option("--min-points", config.range.range.min_points, "kept points needed for a distance")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_flag("--surface", config.range.surface,
               "report the distance of the target's visible surface, not of its centre");
  CLI11_PARSE(app, argc, argv);

  return node::run_node<range_service::RangeNode>(app.common, config, [&](const auto& stats) {
    std::cerr << app.common.service << ": answered " << stats.processed << ", ranged "
              << stats.ranged << ", unranged " << stats.unranged << ", bad " << stats.bad
              << ", before the geometry " << stats.no_geometry << "\n";
  });
}
