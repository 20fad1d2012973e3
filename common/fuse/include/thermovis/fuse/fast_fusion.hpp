#pragma once
// Fast two-scale fusion for the 50 Hz pipeline, after guided-filtering fusion (GFF: Li, Kang, Hu,
// "Image fusion with guided filtering", IEEE TIP 2013), with every smooth quantity computed on a
// grid reduced by `scale` (He & Sun's fast guided filter, 2015):
//  - base layers are box means (side base_box_px) of the inputs, detail = input - base;
//  - saliency = Gaussian(|Laplacian|) of each input, the binary map P = [S_ir > S_vis];
//  - base weight = guided filter of P (guide: infrared, radius base_radius_px, eps base_eps),
//    detail weight = guided filter of P (guide: infrared, radius detail_radius_px, eps
//    detail_eps) whose linear coefficients are upsampled and applied to the full-resolution
//    guide, so the weight follows the infrared edges at full resolution; both clipped to [0, 1];
//  - F = W_B B_ir + (1 - W_B) B_vis + W_D D_ir + (1 - W_D) D_vis.
// Only the detail term and the final sum run at full resolution, in one pass.
#include <vector>

#include <opencv2/core/mat.hpp>

namespace thermovis::fuse {

struct FastFusionParams {
  int scale = 8;         // reduction of the working grid (1 = full resolution); 4: better, slower
  int base_box_px = 31;  // side of the base-layer box mean, full-resolution pixels
  double saliency_sigma_px = 5;  // Gaussian smoothing of |Laplacian|, full-resolution pixels
  int base_radius_px = 45;       // base weight guided filter radius, full-resolution pixels
  double base_eps = 0.3;         // intensities in [0, 1]
  int detail_radius_px = 7;      // detail weight guided filter radius, full-resolution pixels
  double detail_eps = 1e-3;
};

// infrared: CV_8UC1. visible: one or more CV_8UC1 planes (colour channels or luminance) of the
// same size; decision_visible: the CV_8UC1 plane whose saliency competes with the infrared
// (the luminance for colour input). `fused` receives one CV_8UC1 plane per visible plane; its
// buffers are reused when they already have the right size (video), as are this thread's
// intermediate buffers.
void fast_fuse(const cv::Mat& infrared, const std::vector<cv::Mat>& visible,
               const cv::Mat& decision_visible, std::vector<cv::Mat>& fused,
               const FastFusionParams& params = {});

// The same, returning new planes.
std::vector<cv::Mat> fast_fuse(const cv::Mat& infrared, const std::vector<cv::Mat>& visible,
                               const cv::Mat& decision_visible,
                               const FastFusionParams& params = {});

}  // namespace thermovis::fuse
