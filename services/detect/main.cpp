// thermovis-detect: detections of people (warm blobs or the trained infrared classifier,
// optionally HOG) on the rectified frames.
#include <CLI/CLI.hpp>
#include <iostream>

#include "detect_node.hpp"
#include "thermovis/detect/infrared_classifier.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/runtime/rig_io.hpp"

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
  app.add_option("--reduced-px-per-rad", config.detect.reduced_px_per_rad,
                 "detect on the infrared grid reduced by an integer factor to about this "
                 "resolution (0: the grid's own)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  std::string infrared_detector = "warm-blob";
  std::string model;
  app.add_option("--ir-detector", infrared_detector,
                 "infrared people: warm-blob (tuned on the simulator) or classifier (candidates "
                 "scored by the trees trained on real annotated frames)")
      ->capture_default_str()
      ->check(CLI::IsMember({"warm-blob", "classifier"}));
  app.add_option("--ir-model", model,
                 std::string("classifier model file (default: the shipped ") +
                     detect::kShippedInfraredModel + ")");
  app.add_option("--min-score", config.detect.min_score,
                 "classifier: the trees' vote a box needs (> 0: person)")
      ->capture_default_str();
  int debug_delay_ms = 0;
  app.add_option("--debug-delay-ms", debug_delay_ms,
                 "spend this much longer on every frame (overload tests)")
      ->check(CLI::NonNegativeNumber);
  app.add_deadline_option("DEADLINE QoS period of the frame topics");
  CLI11_PARSE(app, argc, argv);
  if (infrared_detector == "classifier") {
    try {
      config.detect.infrared_model = model.empty()
                                         ? runtime::shipped_file(detect::kShippedInfraredModel)
                                         : std::filesystem::path(model);
      const detect::InfraredClassifier check(config.detect.infrared_model);
    } catch (const std::exception& e) {
      std::cerr << "thermovis-detect: error: --ir-model: " << e.what() << "\n";
      return 2;
    }
  } else if (!model.empty()) {
    std::cerr << "thermovis-detect: error: --ir-model needs --ir-detector classifier\n";
    return 2;
  }
  config.deadline = app.deadline();
  config.debug_delay = std::chrono::milliseconds(debug_delay_ms);

  return node::run_node<detect_service::DetectNode>(app.common, config, [&](const auto& stats) {
    std::cerr << app.common.service << ": processed " << stats.processed << ", dropped "
              << stats.dropped << ", bad " << stats.bad << ", repeated " << stats.repeated
              << ", detections " << stats.detections << "\n";
  });
}
