#pragma once
// Dense disparity of a rectified pair (rows are epipolar lines: camera/rectified.hpp), the
// obstacle stage's input: OpenCV's block matching (StereoBM, the default: about a tenth of
// semi-global matching's CPU) or semi-global matching (StereoSGBM, three paths).
//
// Images: CV_8UC1 grey, both eyes the same size. Disparity: CV_32FC1, px, left column - right
// column (> 0 in front), sub-pixel (1/16 px steps); NaN where the matcher gives none (no
// texture, not unique, occluded, speckle, the left border the search range cannot see).
#include <opencv2/core/mat.hpp>
#include <string>

namespace thermovis::obstacle {

enum class DenseMethod { block_matching, semi_global };
std::string method_name(DenseMethod method);
// "bm" | "sgbm"; std::invalid_argument otherwise.
DenseMethod parse_dense_method(const std::string& name);

struct DenseOptions {
  DenseMethod method = DenseMethod::block_matching;
  int block_size = 7;          // odd, px
  int uniqueness_ratio = 12;   // %: the best cost must beat the second by this
  int texture_threshold = 16;  // block matching: the block's texture below this -> none
  // Block matching: and below this many times the texture the image's noise alone gives a block
  // (image_noise_sigma, an upper bound); 0: texture_threshold alone. On a featureless surface
  // (the far road, a uniform verge) the matcher otherwise finds disparities in the sensor's
  // noise (the uniqueness test does not reject them), and patches of them at one disparity
  // stand above the ground as obstacles: 56 per 100 empty-road frames with texture_threshold
  // alone, 2 with 2, none with 2.5 and 3 (in 50 frames), where 3 loses targets at 10-20 m
  // (`thermovis bench obstacles --texture-noise-factor`, docs/obstacles.md).
  double texture_noise_factor = 2.5;
  int speckle_window = 40;   // px: smaller islands of disparity are removed (0: kept)
  int speckle_range_px = 1;  // the disparity change within an island, px
};

// Disparity over [0, max_disparity_px] (rounded up to a multiple of 16). Throws
// std::invalid_argument naming the image that is empty, of another type or size, or a bad
// option.
cv::Mat dense_disparity(const cv::Mat& left, const cv::Mat& right, double max_disparity_px,
                        const DenseOptions& options = {});

// The standard deviation of a grey image's noise (CV_8UC1), grey levels, from its 3 x 3
// Laplacian difference (Immerkaer 1996); texture makes it an upper bound. 0 for an image under
// 3 x 3 px. Throws std::invalid_argument for another type.
double image_noise_sigma(const cv::Mat& grey);
// The texture threshold block matching uses on a left image: texture_threshold, or
// texture_noise_factor times the texture the image's noise gives a block where that is more.
int block_texture_threshold(const cv::Mat& left, const DenseOptions& options);

// The share of a left image's blocks (0..1, those wholly inside it) whose texture reaches
// block_texture_threshold: more than the share of pixels block matching can give a disparity.
double textured_share(const cv::Mat& left, const DenseOptions& options);

// A pair as the matcher reads it: CV_8UC1 kept, CV_8UC3 (BGR) to grey, CV_16UC1 (infrared
// counts, 0 outside the camera's field) as their local detail (less the 9 x 9 mean) around grey
// 128, at one gain for both eyes (so that a point is the same grey in both): 3 robust sigmas of
// the left eye's detail over 64 grey levels, less where that makes the left image's noise
// (image_noise_sigma) more than kMaxCountsNoiseGrey. Throws std::invalid_argument for another
// type or eyes of different sizes or types.
inline constexpr double kMaxCountsNoiseGrey = 3.0;
void grey_pair(const cv::Mat& left, const cv::Mat& right, cv::Mat& left8, cv::Mat& right8);

// A dense disparity against a ground truth (CV_32FC1 of the same size, px; non-finite or <= 0
// where unknown), Middlebury's way: bad-1 and bad-2 are the shares of the pixels with a truth
// whose disparity is off by more than 1 and 2 px, a pixel without a disparity counted bad;
// `valid` is the share of those pixels with a disparity, and the _valid figures are over them
// alone. Throws std::invalid_argument for another type or size.
struct DenseAccuracy {
  int truth_pixels = 0;
  double valid = 0, bad1 = 0, bad2 = 0, bad1_valid = 0, bad2_valid = 0;  // shares, 0..1
};
DenseAccuracy evaluate_dense(const cv::Mat& disparity, const cv::Mat& ground_truth);

}  // namespace thermovis::obstacle
