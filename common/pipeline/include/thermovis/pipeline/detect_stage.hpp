#pragma once
// Stage 2: people in the left eye of the pipeline grid. Warm blobs on the rectified infrared
// counts (detect/detectors.hpp: the grid's rows give the ground prior), optionally OpenCV's HOG
// people detector on the fused image, merged by non-maximum suppression, strongest first.
#include <opencv2/core/mat.hpp>
#include <vector>

#include "thermovis/detect/detectors.hpp"
#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::pipeline {

struct DetectOptions {
  detect::WarmBlobOptions blobs;
  bool hog = false;  // also run the HOG people detector on the fused left image
  detect::HogOptions hog_options{0.5, 0.0, 1.05};
  double nms_iou = 0.3;
};

class DetectStage {
 public:
  DetectStage(const PipelineGeometry& geometry, const DetectOptions& options = {});
  bool wants_fused() const { return options_.hog; }
  // infrared: the rectified left infrared (CV_16UC1 counts or CV_8UC1) on the grid; fused: the
  // fused left image, or empty (then only the infrared is used). Throws std::invalid_argument for
  // another type or size.
  std::vector<detect::Detection> detect(const cv::Mat& infrared, const cv::Mat& fused = {}) const;

 private:
  camera::RectifiedCamera grid_;
  DetectOptions options_;
};

}  // namespace thermovis::pipeline
