#pragma once
// The detector flags that `thermovis detect` and `thermovis detect-eval` share.
#include <CLI/CLI.hpp>
#include <stdexcept>
#include <string>

#include "thermovis/detect/person_detector.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace thermovis::cli {

inline constexpr const char* kShippedModel = detect::kShippedInfraredModel;

struct DetectorFlags {
  std::string band = "infrared";
  std::string infrared_detector = "classifier";
  std::string model;  // empty: the shipped one
  std::string visible_detector = "hog";
  int visible_max_side_px = -1;  // -1: the library default
  double min_score = 0.0;
  double nms_iou = -1;  // -1: the library default

  void add_to(CLI::App& app) {
    app.add_option("--band", band, "infrared, visible or fused (infrared + visible)")
        ->capture_default_str();
    app.add_option("--ir-detector", infrared_detector,
                   "infrared band: classifier (candidates scored by the trained trees) or "
                   "warm-blob (the simulator-tuned threshold detector)")
        ->capture_default_str();
    app.add_option(
        "--model", model,
        "classifier model file (default: the shipped " + std::string(kShippedModel) + ")");
    app.add_option("--min-score", min_score,
                   "classifier: the score an infrared box needs (the trees' vote; > 0 person)")
        ->capture_default_str();
    app.add_option("--nms-iou", nms_iou,
                   "a box overlapping a better one by more than this IoU is dropped (default "
                   "0.4)");
    app.add_option("--visible-detector", visible_detector,
                   "visible band: hog, haar-fullbody or haar-upperbody")
        ->capture_default_str();
    app.add_option("--visible-max-side", visible_max_side_px,
                   "visible images are reduced to this longer side (px) first; 0 = full size "
                   "(default 640)");
  }

  detect::PersonDetector make() const {
    detect::PersonDetectorOptions o;
    o.band = detect::parse_band(band);
    o.visible_method = detect::parse_visible_method(visible_detector);
    if (visible_max_side_px >= 0) o.visible_max_side_px = visible_max_side_px;
    o.min_score = min_score;
    if (nms_iou >= 0) o.nms_iou = nms_iou;
    if (infrared_detector == "classifier") {
      o.infrared_model =
          model.empty() ? runtime::shipped_file(kShippedModel) : std::filesystem::path(model);
    } else if (infrared_detector != "warm-blob") {
      throw std::invalid_argument("--ir-detector '" + infrared_detector +
                                  "': expected classifier or warm-blob");
    }
    return detect::PersonDetector(o);
  }
};

}  // namespace thermovis::cli
