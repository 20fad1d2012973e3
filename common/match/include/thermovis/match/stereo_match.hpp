#pragma once
// Stereo correspondences inside one target box of a rectified pair.
//
// Images: the two eyes of one rectified grid (camera/rectified.hpp), so an epipolar line is one
// row and a scene point seen at column xL in the left image is at xR = xL - d in the right one,
// with disparity d >= 0 (px) growing as the point comes closer. Pixels: x = column, y = row,
// centres at integer coordinates (OpenCV's convention). Input images are 8-bit, one channel
// (BGR is converted to grey); 16-bit raw infrared must go through an AGC first.
//
// Methods (all end in the same row-model RANSAC and sub-pixel refinement along the row):
//  - orb, akaze, sift: OpenCV features2d keypoints + descriptors in the box, matched to the
//    keypoints of a search band of the right image (same rows +- row_tolerance_px, disparity in
//    [min, max]), Lowe's ratio test;
//  - ncc: FAST corners in the box, each searched along its row of the right image by zero-mean
//    normalised cross-correlation (ZNCC) over the whole disparity range, kept when the peak is
//    unique and the right-to-left search returns to it (no descriptors: the epipolar constraint
//    does the matching);
//  - sgbm: dense semi-global block matching (cv::StereoSGBM) on the box's band, every
//    `dense_step`-th pixel of the box with a valid disparity (for boxes with few corners).
// Sub-pixel refinement: the left point is snapped to its pixel and the disparity refined by ZNCC
// parabola, then by Gauss-Newton on the patch (Lucas-Kanade along the row, with gain and offset
// so that the two eyes may differ in exposure).
#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/match/region_align.hpp"

namespace thermovis::match {

enum class Method { orb, akaze, sift, ncc, sgbm };

// "orb" | "akaze" | "sift" | "ncc" | "sgbm"; throws std::invalid_argument naming the choices.
Method parse_method(const std::string& name);
std::string method_name(Method method);
std::vector<Method> all_methods();

struct MatchOptions {
  Method method = Method::ncc;
  double min_disparity_px = 0.0;   // search range of d = xL - xR, px
  double max_disparity_px = 64.0;  //
  double row_tolerance_px = 1.5;   // |yR - yL| allowed before RANSAC (descriptor methods)
  int max_features = 2000;         // keypoints detected in the box (left image)
  double ratio_test = 0.8;         // descriptor methods: best / second-best distance
  int fast_threshold = 12;         // ncc: FAST intensity threshold, grey levels
  // ncc: corners searched per box, the strongest (0 = up to max_features). A near person's box
  // has hundreds; 200 keep matching + ranging of one box within 5 ms on one core, and their
  // mean disparity is already far finer than its bias. (An even spread over the box instead
  // of the strongest matched fewer within 1 px on Middlebury: 84.7 % against 87.5 %.)
  int max_points = 200;
  int patch_radius = 4;              // correlation / refinement patch: (2r+1)^2 px
  double min_zncc = 0.85;            // a refined match below this correlation is dropped
  double uniqueness = 0.05;          // ncc: best ZNCC must exceed the runner-up (|dd| > 1) by this
  bool left_right_check = true;      // ncc: the right-to-left search must return within 1 px
  double ransac_threshold_px = 1.0;  // row-model inlier threshold, px
  int ransac_iterations = 64;
  bool subpixel = true;  // refine disparities (off: the method's own positions)
  int dense_step = 2;    // sgbm: take every dense_step-th pixel of the box
};

struct Correspondence {
  Eigen::Vector2d left =
      Eigen::Vector2d::Zero();  // left rectified pixel (integer-snapped when refined)
  Eigen::Vector2d right = Eigen::Vector2d::Zero();  // right rectified pixel, same row model
  double disparity_px = 0.0;                        // left.x - right.x
  double score = 0.0;  // ZNCC of the refined patch (1 = identical), or SGBM: 1
};

struct MatchResult {
  std::vector<Correspondence> matches;
  cv::Rect box;            // the box actually used (clipped to the image)
  int keypoints_left = 0;  // detected in the box
  int candidates = 0;      // matched before RANSAC / refinement
  int ransac_inliers = 0;  // after the row model
  double row_offset_px =
      0.0;  // RANSAC row model: yR - yL = row_offset + row_slope * (xL - box centre)
  double row_slope = 0.0;
  // The whole box's (or its silhouette's) alignment, when the caller asked for it
  // (pipeline::MatchStage does): status empty_region otherwise.
  RegionDisparity region;
};

// Matches inside `box` (left image) against the right image. Throws std::invalid_argument for
// images of different size, empty, or not 8-bit (1 or 3 channels), or a disparity range with
// max < min; a box that is empty or outside the image gives an empty result with box empty.
MatchResult match_box(const cv::Mat& left, const cv::Mat& right, const cv::Rect& box,
                      const MatchOptions& options);

// Refines the disparity of a left pixel (integer position) starting from `disparity_px`:
// ZNCC parabola over +-2 px, then Gauss-Newton with gain and offset on the (2r+1)^2 patch.
// Returns false when the patch leaves either image or the correlation stays below
// options.min_zncc. `row_offset_px` shifts the right row (rectification residual).
bool refine_disparity(const cv::Mat& left_grey, const cv::Mat& right_grey, const cv::Point& left,
                      double row_offset_px, const MatchOptions& options, double& disparity_px,
                      double& zncc);

}  // namespace thermovis::match
