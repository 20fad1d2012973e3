// thermovis-detect: detections of people (warm blobs, optionally HOG) on the rectified frames.
#include <CLI/CLI.hpp>
#include <iostream>

#include "detect_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-detect", "people and warm objects in the rectified frames",
                       /*with_rig=*/false);
  detect_service::DetectConfig config;
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
  app.add_deadline_option("DEADLINE QoS period of the frame topics");
  CLI11_PARSE(app, argc, argv);
  config.deadline = app.deadline();
  config.debug_delay = std::chrono::milliseconds(debug_delay_ms);

  return node::run_node<detect_service::DetectNode>(app.common, config, [&](const auto& stats) {
    std::cerr << app.common.service << ": processed " << stats.processed << ", dropped "
              << stats.dropped << ", bad " << stats.bad << ", repeated " << stats.repeated
              << ", detections " << stats.detections << "\n";
  });
}
