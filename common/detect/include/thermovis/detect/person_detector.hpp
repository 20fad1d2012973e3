#pragma once
// The detection stage's one entry point: people in an infrared image, a visible image or both
// (registered: one box serves both), with or without the rectified geometry.
//  - infrared: CV_16UC1 raw counts or CV_8UC1 (gain-controlled by the camera); pixels of value
//    0 are outside the field;
//  - visible: CV_8UC1 or CV_8UC3 (BGR), same size as the infrared image when both are given;
//  - grid: the rectified grid of the images (rows give the angle below the horizon), or null
//    for a plain image of unknown geometry. With a grid, infrared boxes must also be as tall as
//    a person standing on the ground at the distance their foot row gives.
// Boxes are in the pixels of the image given (x = column, y = row), each with its class and a
// score (higher = more confident; comparable between the boxes of one band and detector).
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/detect/detectors.hpp"
#include "thermovis/detect/infrared_classifier.hpp"

namespace thermovis::detect {

// The infrared classifier shipped with thermovis (trained by `thermovis detect-train` on the
// training frames of the shared annotated sets), relative to the shipped files' folder
// (runtime::shipped_file).
inline constexpr const char* kShippedInfraredModel = "models/person_ir.yml.gz";

enum class Band { infrared, visible, fused };
Band parse_band(const std::string& name);  // "infrared", "visible", "fused"
std::string band_name(Band band);

// Visible-band detectors: OpenCV's HOG people detector (INRIA, 64 x 128 window) and the Haar
// full-body and upper-body cascades of Debian's opencv-data.
enum class VisibleMethod { hog, haar_fullbody, haar_upperbody };
VisibleMethod parse_visible_method(const std::string& name);  // "hog", "haar-fullbody", ...
std::string visible_method_name(VisibleMethod method);

struct PersonDetectorOptions {
  Band band = Band::infrared;
  // Infrared: the trained classifier's model file (see infrared_classifier.hpp); empty = the
  // warm-blob detector (detect_warm_blobs), tuned on the simulator.
  std::filesystem::path infrared_model;
  CandidateOptions candidates;
  double min_score = 0.0;  // classifier score a box needs (> 0: person by the trained trees)
  WarmBlobOptions warm_blob;
  VisibleMethod visible_method = VisibleMethod::hog;
  HogOptions hog;
  // Visible images are reduced so that their longer side is at most this many pixels before
  // the visible detectors run (their cost grows with the area; 0 = full size).
  int visible_max_side_px = 640;
  std::filesystem::path cascade_dir = "/usr/share/opencv4/haarcascades";
  // fused: an infrared box confirmed by a visible box (IoU >= fuse_iou) gains fuse_bonus on its
  // score; visible boxes that no infrared box explains are kept at a score below every
  // infrared one (infrared is the band that sees people at night).
  double fuse_iou = 0.3;
  double fuse_bonus = 1.0;
  double nms_iou = 0.4;  // boxes overlapping a better one by more than this are dropped
};

class PersonDetector {
 public:
  // Throws std::runtime_error naming the file when the model or a cascade the options need
  // cannot be read.
  explicit PersonDetector(PersonDetectorOptions options = {});
  ~PersonDetector();
  PersonDetector(PersonDetector&&) noexcept;
  PersonDetector& operator=(PersonDetector&&) noexcept;

  // Throws std::invalid_argument for an image of another type, an empty image the band needs,
  // two images of different sizes or an image whose size differs from the grid's.
  std::vector<Detection> detect(const cv::Mat& infrared, const cv::Mat& visible,
                                const camera::RectifiedCamera* grid = nullptr);

  const PersonDetectorOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace thermovis::detect
