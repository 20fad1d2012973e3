#include "thermovis/pipeline/detect_stage.hpp"

#include <stdexcept>

namespace thermovis::pipeline {

DetectStage::DetectStage(const PipelineGeometry& geometry, const DetectOptions& options)
    : grid_(geometry.grid), options_(options) {
  if (!options_.infrared_model.empty()) {
    detect::PersonDetectorOptions o;
    o.band = detect::Band::infrared;
    o.infrared_model = options_.infrared_model;
    o.min_score = options_.min_score;
    o.warm_blob = options_.blobs;
    o.nms_iou = options_.nms_iou;
    classifier_ = std::make_shared<detect::PersonDetector>(o);
  }
}

std::vector<detect::Detection> DetectStage::detect(const cv::Mat& infrared,
                                                   const cv::Mat& fused) const {
  if (infrared.type() != CV_8UC1 && infrared.type() != CV_16UC1) {
    throw std::invalid_argument("detect: infrared image: expected MONO8 or MONO16 pixels");
  }
  std::vector<detect::Detection> found =
      classifier_ ? classifier_->detect(infrared, cv::Mat(), &grid_)
                  : detect::detect_warm_blobs(infrared, grid_, options_.blobs);
  if (options_.hog && !fused.empty()) {
    auto people = detect::detect_people_hog(fused, options_.hog_options);
    found.insert(found.end(), people.begin(), people.end());
  }
  return detect::merge_detections(std::move(found), options_.nms_iou);
}

}  // namespace thermovis::pipeline
