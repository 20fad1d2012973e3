// thermovis-detect: detections of people (warm blobs, optionally HOG) on the rectified frames.
#include <CLI/CLI.hpp>
#include <iostream>

#include "detect_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  CLI::App app{"thermovis-detect: people and warm objects in the rectified frames"};
  node::CommonOptions common;
  common.service = "thermovis-detect";
  detect_service::DetectConfig config;
  double deadline_ms = 20.0;
  node::add_common_options(app, common, /*with_rig=*/false);
  app.add_flag("--hog", config.detect.hog, "also run the HOG people detector on the fused image");
  app.add_option("--k-sigma", config.detect.blobs.k_sigma,
                 "warm blobs: threshold over the background median, robust sigmas")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--camera-height-m", config.detect.blobs.camera_height_m,
                 "height of the rig above the ground (person size check)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  int debug_delay_ms = 0;
  app.add_option("--debug-delay-ms", debug_delay_ms,
                 "spend this much longer on every frame (overload tests)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--deadline-ms", deadline_ms, "DEADLINE QoS period of the frame topics")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  config.deadline = node::deadline_from_ms(deadline_ms);
  config.debug_delay = std::chrono::milliseconds(debug_delay_ms);

  return node::run_service(common, [&] {
    auto participant = node::make_participant(common);
    detect_service::DetectNode detector(*participant, config, common.service);
    detector.run();
    const auto stats = detector.stats();
    std::cerr << common.service << ": processed " << stats.processed << ", dropped "
              << stats.dropped << ", bad " << stats.bad << ", repeated " << stats.repeated
              << ", detections " << stats.detections << "\n";
  });
}
