#pragma once
// Whole-target disparity: one target's region of the left rectified image aligned with the right
// image along its row, using every pixel of the region rather than only its corners.
//
// Images and pixels as in stereo_match.hpp: one rectified grid, 8-bit grey, x = column, y = row,
// a scene point at column xL in the left image is at xR = xL - d in the right one.
//
// Model: the region shifts as a whole by (-d, dy) and its brightness by gain g and offset h:
//   min over d, dy, g, h of  sum_i w_i (g R(x_i - d, y_i + dy) + h - L(x_i, y_i))^2,
// solved by Gauss-Newton (Lucas-Kanade) on a separable Catmull-Rom interpolation of R (value
// and derivatives from one kernel; bilinear would pull d towards whole pixels), from an integer
// start found by zero-mean normalised correlation of the whole region along the row. The weights
// are the region's mask (and a one-pixel ring around it, the outline's outer side, unless the
// region correlates better without it: a textured background behind the outline) times Tukey's
// biweight of the residual (iteratively reweighted, each pixel's scale including what half a
// pixel of misalignment makes of its gradient), so that pixels of the background inside the
// region and the outline's changes between the eyes count less. A weak prior holds the gain at
// 1 where the region has no contrast of its own. One translation for the whole region is the
// fronto-parallel model: right for a target whose depth extent is small against its distance (a
// person beyond a few metres).
//
// The disparity's uncertainty is the Gauss-Newton covariance: residual variance times
// (J^T W J)^-1 for d. It is the random part only; the caller adds the floors its error budget
// needs (rectification residual, target shape).
#include <Eigen/Core>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <string>

namespace thermovis::match {

enum class RegionStatus {
  ok,
  empty_region,     // no area, outside the image, or a mask with no pixel set
  at_image_edge,    // the box is cut by the image edge, or the region leaves the right image at
                    // every candidate disparity
  flat,             // too little horizontal gradient to align (uniform or saturated region)
  ambiguous,        // the correlation has two peaks of nearly the same height
  low_correlation,  // the best alignment correlates below min_zncc
  no_convergence,   // Gauss-Newton left the search range or did not settle
  not_aligned,      // the caller did not ask for it (pipeline::MatchStage: enough points)
};
std::string region_status_name(RegionStatus status);

struct RegionOptions {
  double min_disparity_px = 0.0;   // search range of d
  double max_disparity_px = 64.0;  //
  // The row offset the alignment starts from at disparity d: row_offset_px +
  // row_offset_per_disparity * d. The second term is a pair shown on another pair's grid,
  // whose right eye is off the grid's baseline (range::RangingGeometry::right_centre_m).
  double row_offset_px = 0.0;
  double row_offset_per_disparity = 0.0;
  // Around a given initial disparity the integer search spans +- this many px.
  int search_radius_px = 3;
  int max_iterations = 15;
  double uniqueness = 0.02;  // the integer peak must exceed the runner-up (|dd| > 1) by this
  int max_pixels = 4000;     // larger regions are subsampled on a regular lattice
  // Spread (RMS about its mean) of the region's horizontal gradient, grey levels / px: below it
  // the region is flat (or a plain ramp) and gives no disparity.
  double min_gradient = 1.5;
  double min_zncc = 0.85;  // of the final alignment, over the weighted region
  double tukey_c = 4.685;  // biweight cut-off in robust standard deviations of the residual
  // A pixel's residual scale includes what this misalignment makes of its gradient (outline
  // pixels are steep: a fit not yet settled leaves them the largest residuals).
  double position_tolerance_px = 0.5;
  // Weight of the one-pixel ring around a mask (the outline's outer side) against the mask's
  // own pixels. Without it a uniformly warm body has nothing to align but its inner edge
  // pixels, whose gain is then undetermined.
  double ring_weight = 1.0;
  // Pixels within this distance of the mask's outline form the contour band
  // (RegionDisparity::contour_fraction).
  double contour_band_px = 2.0;
};

struct RegionDisparity {
  static constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  RegionStatus status = RegionStatus::empty_region;
  std::string message;  // why there is no disparity (empty when ok)
  double disparity_px = nan;
  double sigma_px = nan;     // one sigma, random part (Gauss-Newton covariance)
  double row_offset_px = 0;  // dy of the alignment
  double gain = 1, offset = 0;
  double zncc = 0;  // weighted correlation of the aligned region
  // The left pixel the disparity belongs to: the centroid of the region's pixels.
  Eigen::Vector2d anchor = Eigen::Vector2d::Constant(nan);
  int pixels = 0;  // pixels used (after subsampling)
  // Share of the alignment's information (sum of w * (dR/dx)^2) that comes from the contour
  // band of the region's outline: near 1 when only the silhouette's edge carries texture (a
  // uniformly warm body in infrared), lower when the inside is textured (clothing by day).
  double contour_fraction = nan;
  // Whether the one-pixel ring around the mask took part: it is dropped when the region
  // correlates better without it (a textured background behind the outline).
  bool ring_used = false;
  bool ok() const { return status == RegionStatus::ok; }
};

// Aligns `box` of the left image (masked by `mask`: CV_8UC1 of the box's size, non-zero = the
// target; empty = the whole box) with the right image. `initial_disparity_px` (finite) narrows
// the integer search to +- options.search_radius_px around it; NaN searches the whole range.
// Throws std::invalid_argument for images that are not CV_8UC1 of one size, a mask of another
// size or type, or max < min disparity; bad content gives a status, never a number.
RegionDisparity align_region(const cv::Mat& left, const cv::Mat& right, const cv::Rect& box,
                             const cv::Mat& mask, double initial_disparity_px,
                             const RegionOptions& options);

// The silhouette of a target that differs in brightness from its surroundings inside `box`
// (infrared: a warm body, or a cold one against warm ground), from an image of CV_8UC1 or
// CV_16UC1. Otsu's threshold splits the box's pixels; the target's side is the one that fills
// the box's central part more than its border ring. Returns a CV_8UC1 mask of the box's size
// (255 on the target's side; zero outside the image), or an empty Mat when the box does not
// split (the target side under 10 % or over 95 % of the box, or a uniform box).
cv::Mat target_silhouette(const cv::Mat& image, const cv::Rect& box);

}  // namespace thermovis::match
