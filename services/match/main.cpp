// thermovis-match: stereo correspondences inside each detected box.
#include <CLI/CLI.hpp>
#include <iostream>

#include "match_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-match", "stereo correspondences of every detected target",
                       /*with_rig=*/false);
  match_service::MatchConfig config;
  std::string method = "ncc";
  std::string band = "both";
  app.add_option("--band", band,
                 "frames to match: both (each box on both pairs; the range stage combines "
                 "them) | auto (visible, infrared where visible finds too few points) | visible "
                 "| infrared | fused")
      ->capture_default_str()
      ->check(CLI::IsMember({"both", "auto", "visible", "infrared", "fused"}));
  app.add_option("--min-visible-points", config.match.min_visible_points,
                 "auto: fewer visible correspondences than this -> the infrared pair")
      ->capture_default_str();
  app.add_option("--method", method, "ncc | orb | akaze | sift | sgbm")->capture_default_str();
  app.add_option("--min-distance-m", config.match.min_distance_m,
                 "nearest target searched (sets the largest disparity)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--frames-kept", config.frames_kept,
                 "rectified frames kept per band for detections still to come (cover the "
                 "detector's latency: at 50 Hz, 4 frames are 80 ms)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_deadline_option("DEADLINE QoS period of the frame topic");
  CLI11_PARSE(app, argc, argv);
  config.deadline = app.deadline();

  return node::run_service(app.common, [&] {
    config.match.match.method = match::parse_method(method);
    config.match.band = pipeline::parse_band_choice(band);
    auto participant = node::make_participant(app.common);
    match_service::MatchNode matcher(*participant, config, app.common.service);
    matcher.run();
    const auto stats = matcher.stats();
    std::cerr << app.common.service << ": answered " << stats.processed << ", without frame "
              << stats.no_frame << ", bad " << stats.bad << ", overwritten while copied "
              << stats.overwritten << ", points " << stats.points << ", on infrared "
              << stats.infrared_targets << " (left out for room " << stats.infrared_left_out
              << ")\n";
  });
}
