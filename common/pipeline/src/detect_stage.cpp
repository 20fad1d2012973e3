#include "thermovis/pipeline/detect_stage.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace thermovis::pipeline {

DetectStage::DetectStage(const PipelineGeometry& geometry, const DetectOptions& options)
    : grid_(geometry.image_grid(Band::infrared)),
      options_(options),
      reduction_(grid_reduction(grid_.intrinsics(), options.reduced_px_per_rad)),
      reduced_grid_(reduce_grid(grid_.intrinsics(), reduction_)),
      to_grid_(reduction_ * geometry.infrared_reduction) {
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
  if (infrared.size() != grid_.image_size()) {
    throw std::invalid_argument("detect: infrared image is " + std::to_string(infrared.cols) + "x" +
                                std::to_string(infrared.rows) + ", the infrared pair's grid " +
                                std::to_string(grid_.image_size().width) + "x" +
                                std::to_string(grid_.image_size().height));
  }
  const int k = reduction_;
  cv::Mat image = infrared;
  if (k > 1) reduce_image(infrared, k, image);
  const camera::RectifiedCamera& grid = k > 1 ? reduced_grid_ : grid_;
  std::vector<detect::Detection> found =
      classifier_ ? classifier_->detect(image, cv::Mat(), &grid)
                  : detect::detect_warm_blobs(image, grid, options_.blobs);
  if (const int g = to_grid_; g > 1) {
    for (detect::Detection& d : found)
      d.box = cv::Rect(d.box.x * g, d.box.y * g, d.box.width * g, d.box.height * g);
  }
  if (options_.hog && !fused.empty()) {
    auto people = detect::detect_people_hog(fused, options_.hog_options);
    found.insert(found.end(), people.begin(), people.end());
  }
  return detect::merge_detections(std::move(found), options_.nms_iou);
}

}  // namespace thermovis::pipeline
