#pragma once
// Stage 2: people in the left eye of the pipeline grid. On the rectified infrared (the grid's
// rows give the ground prior): warm blobs (detect/detectors.hpp, tuned on the simulator), or the
// trained infrared classifier of detect/person_detector.hpp (candidates scored by boosted trees,
// trained on real annotated frames) when a model is given. Optionally OpenCV's HOG people
// detector on the fused image. Merged by non-maximum suppression, strongest first.
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "thermovis/detect/detectors.hpp"
#include "thermovis/detect/person_detector.hpp"
#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::pipeline {

struct DetectOptions {
  detect::WarmBlobOptions blobs;  // also the classifier's person-height check on the ground
  // The infrared classifier's model file (detect::kShippedInfraredModel is the shipped one);
  // empty: warm blobs.
  std::filesystem::path infrared_model;
  double min_score = 0.0;  // classifier: the trees' vote a box needs
  bool hog = false;        // also run the HOG people detector on the fused left image
  detect::HogOptions hog_options{0.5, 0.0, 1.05};
  double nms_iou = 0.3;
  // The infrared detector runs on the infrared image reduced by an integer factor to about this
  // many px per rad (box-filtered; the boxes scaled back to the grid): lround(f / this) of the
  // infrared pair's grid (PipelineGeometry::image_grid), at least 1. The warm
  // blobs' and the classifier's pixel sizes were tuned on the pipeline grid (417 px/rad), where
  // the factor is 1; the full grid (835 px/rad) has twice the rows and columns of the infrared
  // cameras' own resolution, and detection there cost 2.5x the pipeline grid's for no more
  // people found. 0: never reduced.
  double reduced_px_per_rad = 420.0;
};

class DetectStage {
 public:
  // Throws std::runtime_error naming the file when the infrared model cannot be read, and
  // std::invalid_argument for a negative or non-finite reduced_px_per_rad.
  DetectStage(const PipelineGeometry& geometry, const DetectOptions& options = {});
  bool wants_fused() const { return options_.hog; }
  // Of the infrared image before detection (the infrared pair's own reduction apart).
  int reduction() const { return reduction_; }
  // infrared: the rectified left infrared (CV_16UC1 counts or CV_8UC1) on the infrared pair's
  // grid (PipelineGeometry::image_size); fused: the fused left image on the grid, or empty (then
  // only the infrared is used). Boxes are on the grid. Throws std::invalid_argument for another
  // type or size.
  std::vector<detect::Detection> detect(const cv::Mat& infrared, const cv::Mat& fused = {}) const;

 private:
  camera::RectifiedCamera grid_;  // the infrared pair's
  DetectOptions options_;
  int reduction_ = 1;                                   // of the infrared image before detection
  camera::RectifiedCamera reduced_grid_;                // the infrared image at that reduction
  int to_grid_ = 1;                                     // grid px per detection px
  std::shared_ptr<detect::PersonDetector> classifier_;  // with a model only
};

}  // namespace thermovis::pipeline
