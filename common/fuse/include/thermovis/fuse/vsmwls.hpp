#pragma once
// VSM-WLS infrared/visible fusion (Ma, Zhou, Wang, Zong, "Infrared and visible image fusion based
// on visual saliency map and weighted least square optimization", Infrared Physics & Technology
// 82:8-17, 2017), as its authors' MATLAB code (byte-identical in the VIFB benchmark) computes it,
// which is what the stereo paper's Section 2.3 (Eq. 22-30) builds on. Everything is in double
// precision on single-channel CV_64FC1 planes with values in [0, 1].
//
// The reference code, WLS_Fusion(I1, I2), step by step (data/fusion/SOURCES.md has the notes):
//  1. Four-level decomposition of each input: G1 = I, G(i) = RGF(G(i-1)) for i = 2..4 with spatial
//     sigma 2, 4, 8, range sigma 0.05 and 4 iterations (a cascade); d(i-1) = G(i-1) - G(i);
//     G5 = Gaussian(G4, sigma 2), d4 = G4 - G5; the base layer is G5. The RGF is a rolling
//     guidance filter whose smoothing step is He's guided filter (rolling_guidance_guided below),
//     not the bilateral RGF of OpenCV's ximgproc::rollingGuidanceFilter.
//  2. Visual saliency map of each whole input (Eq. 22-23): V = sum_i h(i) |g - i| over the
//     256-bin histogram h, min-max normalised; base layer BF = (0.5 + (V1 - V2) / 2) B1 +
//     (0.5 + (V2 - V1) / 2) B2 (Eq. 24-25).
//  3. Finest detail layer: binary max-absolute (ties to I1), no smoothing, no WLS.
//  4. Layers 4, 3, 2: C = [|d_I1| < |d_I2|] smoothed by a 13x13 Gaussian (sigma 2, 'symmetric'
//     border), M = C d_I2 + (1 - C) d_I1 (Eq. 26-28); then the WLS step (Eq. 29), whose sparse
//     system is diagonal: D = (M + lambda A d_I1) / (1 + lambda A), A = 1 / (|mean7x7(d_I2)| +
//     1e-6), lambda = 0.01.
//  5. I_F = BF + sum D (Eq. 30), not clipped here.
// The reference calls WLS_Fusion(IR, VIS): A comes from the visible detail and D is pulled toward
// the infrared detail. The paper's Eq. 29 states the reverse orientation, a window sum and
// epsilon 1e-4, and Eq. 27 smooths the weights of every layer: VsmWlsParams::paper() gives that
// reading (call it with the visible image as I1).
#include <opencv2/core/mat.hpp>

namespace thermovis::fuse {

struct VsmWlsParams {
  int levels = 4;                      // decomposition levels (3 rolling-guidance + 1 Gaussian)
  double sigma_spatial = 2.0;          // first level's spatial sigma (px), doubled per level
  double sigma_range = 0.05;           // guided-filter eps = sigma_range^2 (intensity in [0,1])
  int rgf_iterations = 4;              // rolling-guidance iterations per level
  double weight_sigma = 2.0;           // Gaussian smoothing of the binary detail weights (px)
  double lambda = 0.01;                // WLS regularisation (Eq. 29)
  int wls_window = 7;                  // side of the window of a_p (px)
  bool wls_window_sum = false;         // false: window mean (code); true: window sum (paper)
  double wls_epsilon = 1e-6;           // code 1e-6; paper 1e-4
  bool smooth_finest_weights = false;  // code: finest layer binary; paper: smoothed too

  // The reading of the stereo paper's Eq. 26-29 (use with I1 = visible, I2 = infrared).
  static VsmWlsParams paper();
};

// He, Sun, Tang's O(1) guided filter as guidedfilter.m: box means over (2r+1)^2 windows clipped
// at the border and divided by the true pixel count. guide, input: CV_64FC1 of one size.
cv::Mat guided_filter(const cv::Mat& guide, const cv::Mat& input, int radius, double eps);

// gaussFilter.m: normalised Gaussian of side 2 round(3 sigma) + 1, 'replicate' border.
cv::Mat gaussian_replicate(const cv::Mat& input, double sigma);

// RollingGuidanceFilter_Guided.m: J0 = Gaussian(I, sigma_s); then `iterations` times
// J = guided_filter(guide J, input I, radius sigma_s, eps sigma_r^2).
cv::Mat rolling_guidance_guided(const cv::Mat& input, double sigma_spatial, double sigma_range,
                                int iterations);

// Visual_Weight_Map.m: per-pixel saliency from the 256-bin histogram of round(255 I), min-max
// normalised to [0, 1] (all zero for a constant image).
cv::Mat visual_saliency_map(const cv::Mat& input);

// WLS_Fusion(I1, I2) on CV_64FC1 planes in [0,1] of one size (at least 18x18 px, as the reference
// needs); returns the unclipped fused plane (CV_64FC1).
cv::Mat vsmwls_fuse(const cv::Mat& i1, const cv::Mat& i2, const VsmWlsParams& params = {});

}  // namespace thermovis::fuse
