#pragma once
// The least uncertainty any estimator can have for the shift of a region along the rows
// between two noisy images of it: the Cramer-Rao bound of a translation (Robinson and
// Milanfar 2004, "Fundamental performance limits in image registration"). For a region whose
// noise-free image I is seen in two eyes with independent noise of variances s_l^2 and s_r^2
// per pixel, an unbiased shift estimate has at least the variance
//     (s_l^2 + s_r^2) / sum over the region of (dI/dx)^2,
// gain, offset and a row offset being known (unknown, they only raise it). It is what the
// pixels allow: a mean |error| below sqrt(2 / pi) times it is beyond any matcher.
#include <opencv2/core/mat.hpp>

namespace thermovis::match {

// One sigma of the bound, px of `clean`: `clean` the noise-free left image (CV_8UC1,
// CV_16UC1 or CV_32FC1), `mask` (CV_8UC1, its size) nonzero on the region's pixels (its
// outline included: where it meets the background is most of what a silhouette tells), its
// x gradient the central difference (pixels at the image's left and right edge left out).
// `noise_variance_sum` is s_l^2 + s_r^2 in the image's units squared. Infinity for a region
// without gradient. Throws std::invalid_argument for another type, a mask of another size or
// type, or a variance that is not >= 0.
double shift_bound_px(const cv::Mat& clean, const cv::Mat& mask, double noise_variance_sum);

}  // namespace thermovis::match
