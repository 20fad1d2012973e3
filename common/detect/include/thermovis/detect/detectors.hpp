#pragma once
// Target detection in rectified images, offline (no downloaded weights):
//  - infrared warm blobs: pixels warmer than the frame's background (median + k robust sigmas of
//    the raw counts, so the AGC's equalisation does not move the threshold), grouped into
//    connected components, kept when their shape is upright and their height matches a person
//    standing on the ground at the distance the blob's foot row gives (level rig at a known
//    height: distance = height / tan(angle below the horizon));
//  - visible people: OpenCV's HOG people detector (Dalal-Triggs, 64 x 128 window) on the image
//    reduced by `scale`;
//  - combination: boxes of both sources on one grid merged by non-maximum suppression.
// Boxes are in the pixels of the rectified image given (x = column, y = row).
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/camera/rectified.hpp"

namespace thermovis::detect {

struct Detection {
  cv::Rect box;
  std::string cls = "person";
  double score =
      0.0;  // warm blob: mean excess over the threshold in robust sigmas; HOG: SVM margin
  std::string source;  // "infrared", "visible", "fused", "external"
};

struct WarmBlobOptions {
  double k_sigma = 2.0;          // threshold: background median + k * 1.4826 * MAD
  double min_excess_counts = 0;  // and at least this many counts over the median
  int min_area_px = 15;
  double min_aspect = 1.3;  // height / width of a standing person's box
  double max_aspect = 6.0;
  double person_height_m = 1.75;
  double camera_height_m = 1.4;   // camera centre above the ground
  double height_ratio_min = 0.5;  // measured / expected box height
  double height_ratio_max = 1.8;
};

// The pixels detect_warm_blobs groups into blobs: warmer than the background's median + k robust
// sigmas (and min_excess_counts) over the field's pixels (value > 0), closed by a 3 x 5
// rectangle. Empty mask when the field holds too few pixels for the statistics.
struct WarmMask {
  cv::Mat mask;  // CV_8UC1, 255 where warm
  double threshold = 0.0, sigma = 0.0;
};
WarmMask warm_blob_mask(const cv::Mat& infrared, const WarmBlobOptions& options);

// infrared: rectified CV_16UC1 counts or CV_8UC1 (pixels of value 0 are treated as outside the
// field); grid: its rectified grid (rows give the angle below the horizon). Throws
// std::invalid_argument for another type or a size different from the grid's.
std::vector<Detection> detect_warm_blobs(const cv::Mat& infrared,
                                         const camera::RectifiedCamera& grid,
                                         const WarmBlobOptions& options = {});
// The same without the ground prior when grid is null (a plain image of unknown geometry: only
// the area and aspect tests apply).
std::vector<Detection> detect_warm_blobs(const cv::Mat& infrared,
                                         const camera::RectifiedCamera* grid,
                                         const WarmBlobOptions& options = {});

// Whether a box standing on the ground (its bottom row the foot) is as tall as a person of
// options.person_height_m at the distance that row gives on a level rig at camera_height_m.
bool height_fits_ground(const cv::Rect& box, const camera::RectifiedCamera& grid,
                        const WarmBlobOptions& options);

// One 8-connected component of a binary mask: its bounding box and its pixel count.
struct Component {
  cv::Rect box;
  int area_px = 0;
};

// The 8-connected components of mask (CV_8UC1, non-zero pixels set) with the labels and in the
// order of cv::connectedComponentsWithStats (component i has label i + 1 in `labels`, CV_32S),
// for a fraction of its cost: OpenCV 4.6's statistics pass over every pixel took 3.8 ms of a
// 936 x 566 frame whose labelling took 0.5 ms (bench_detect BM_Components); here the statistics
// come from the set pixels alone. Throws std::invalid_argument for another type.
std::vector<Component> label_components(const cv::Mat& mask, cv::Mat& labels);

struct HogOptions {
  double scale = 1.0;          // image reduction before the detector (0.5 = half size)
  double hit_threshold = 0.0;  // SVM margin
  double pyramid_scale = 1.05;
};

// visible: CV_8UC1 or CV_8UC3 rectified image.
std::vector<Detection> detect_people_hog(const cv::Mat& visible, const HogOptions& options = {});

// Non-maximum suppression: boxes overlapping a higher-scored one by IoU > iou are dropped.
std::vector<Detection> merge_detections(std::vector<Detection> detections, double iou = 0.3);

double intersection_over_union(const cv::Rect& a, const cv::Rect& b);

}  // namespace thermovis::detect
