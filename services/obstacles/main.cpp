// thermovis-obstacles: obstacles of any class and the free space, from the rectified pairs.
#include <CLI/CLI.hpp>
#include <cmath>
#include <iostream>

#include "obstacles_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-obstacles",
                       "obstacles of any class and the free space on thermovis/obstacles",
                       /*with_rig=*/false);
  obstacles_service::ObstaclesConfig config;
  std::string band = "both";
  std::string method = "bm";
  double pitch_deg = 0.0, roll_deg = 0.0, range_wait_ms = 15.0;
  bool no_targets = false;
  app.add_option("--band", band, "pairs searched: both | visible | infrared")
      ->capture_default_str()
      ->check(CLI::IsMember({"both", "visible", "infrared"}));
  app.add_option("--camera-height-m", config.obstacles.mounting.camera_height_m,
                 "the reference camera's height above the ground (the ground search's prior)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--pitch-deg", pitch_deg, "the rig's pitch, optical axis below the horizontal > 0")
      ->capture_default_str()
      ->check(CLI::Range(-30.0, 30.0));
  app.add_option("--roll-deg", roll_deg, "the rig's roll, right side down > 0")
      ->capture_default_str()
      ->check(CLI::Range(-30.0, 30.0));
  app.add_option("--method", method, "dense disparity: bm | sgbm")
      ->capture_default_str()
      ->check(CLI::IsMember({"bm", "sgbm"}));
  app.add_option("--max-distance-m", config.obstacles.obstacles.max_distance_m,
                 "farthest obstacle reported (the free space where none)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_flag("--track-ground", config.track_ground,
               "search each pair's ground about its last capture's (a vehicle that pitches)");
  bool no_far_band = false;
  app.add_flag("--no-far-band", no_far_band,
               "the reduced grid alone: the visible pair not matched again on the grid's own "
               "pixels about the horizon (short objects at 18-45 m then missed, 1-2 ms less CPU)");
  app.add_flag("--no-targets", no_targets,
               "do not merge the ranged targets of thermovis/ranges (obstacles only)");
  app.add_option("--range-wait-ms", range_wait_ms,
                 "how long a capture's obstacles wait for its ranges")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  CLI11_PARSE(app, argc, argv);
  config.obstacles.visible = band != "infrared";
  config.obstacles.infrared = band != "visible";
  config.obstacles.mounting.pitch_rad = pitch_deg * M_PI / 180.0;
  config.obstacles.mounting.roll_rad = roll_deg * M_PI / 180.0;
  config.with_targets = !no_targets;
  config.obstacles.obstacles.far_band = !no_far_band;
  config.range_wait = std::chrono::milliseconds(static_cast<long>(std::lround(range_wait_ms)));

  return node::run_service(app.common, [&] {
    config.obstacles.obstacles.dense.method = obstacle::parse_dense_method(method);
    auto participant = node::make_participant(app.common);
    obstacles_service::ObstaclesNode node(*participant, config, app.common.service);
    node.run();
    const auto s = node.stats();
    std::cerr << app.common.service << ": published " << s.processed << " (one pair only "
              << s.one_pair << ", without ranges " << s.without_ranges << "), bad " << s.bad
              << ", overwritten while read " << s.overwritten << ", skipped " << s.skipped
              << ", pairs without ground " << s.no_ground << ", obstacles " << s.obstacles
              << " (ranged targets " << s.targets << ")\n";
  });
}
