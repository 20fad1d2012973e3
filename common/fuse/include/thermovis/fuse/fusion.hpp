#pragma once
// Infrared/visible fusion of one registered pair: method and colour handling around the
// single-plane algorithms of vsmwls.hpp and fast_fusion.hpp.
//
// Pixel formats:
//  - infrared: CV_8UC1, or CV_8UC3 (VIFB stores most infrared images as RGB with R = G = B), or
//    CV_32FC1 / CV_64FC1 intensities in [0, 1];
//  - visible: CV_8UC1 or CV_8UC3 (BGR), or CV_32F / CV_64F with 1 or 3 channels in [0, 1];
//  - both of one size. Float input must be finite (NaN/inf are rejected).
// The result is 8-bit with the visible image's channel count (MATLAB im2uint8: clip to [0, 1],
// round half away from zero).
//
// Colour (ColourMode):
//  - per_channel: VIFB's protocol: each visible channel is fused with the infrared (infrared
//    channel k when it has three, else the single plane) and the results stacked;
//  - luminance: the BT.601 luma Y of the visible image is fused with the infrared and the
//    visible chroma kept: every channel is shifted by Y_fused - Y, which leaves BT.601 Cb and Cr
//    (functions of B - Y and R - Y) unchanged except where a channel saturates.
#include <optional>
#include <string>
#include <string_view>

#include <opencv2/core/mat.hpp>

#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fuse/fast_fusion.hpp"
#include "thermovis/fuse/vsmwls.hpp"

namespace thermovis::fuse {

enum class FusionMethod {
  vsmwls,        // the reference VSM-WLS code as VIFB ran it (infrared as I1)
  vsmwls_paper,  // the stereo paper's Eq. 26-29 reading (visible as I1, window sum, eps 1e-4)
  fast,          // fast_fusion.hpp, for the 50 Hz pipeline
};

enum class ColourMode { per_channel, luminance };

struct FusionOptions {
  FusionMethod method = FusionMethod::vsmwls;
  ColourMode colour = ColourMode::per_channel;
  FastFusionParams fast;  // used by FusionMethod::fast
  // Visible contrast enhancement (enhance::enhance_visible's CLAHE) applied to the visible
  // image before it is fused, when set. In luminance mode it works on the luma the fusion uses
  // (one luma extraction and one colour shift for both steps: the pipeline's way).
  std::optional<enhance::VisibleContrastParams> enhance_visible;
};

std::string_view method_name(FusionMethod method);  // "vsmwls", "vsmwls-paper", "fast"
std::optional<FusionMethod> method_from_name(std::string_view name);
std::string_view colour_name(ColourMode mode);  // "rgb", "luminance"
std::optional<ColourMode> colour_from_name(std::string_view name);

// Throws std::invalid_argument naming the problem for empty images, unsupported types or
// channel counts, sizes that differ, or non-finite float pixels.
cv::Mat fuse(const cv::Mat& infrared, const cv::Mat& visible, const FusionOptions& options = {});

// The same into `fused`, whose buffer is reused when it has the right size and type (video).
void fuse(const cv::Mat& infrared, const cv::Mat& visible, cv::Mat& fused,
          const FusionOptions& options);

}  // namespace thermovis::fuse
