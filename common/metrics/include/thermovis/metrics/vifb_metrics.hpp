#pragma once
// Image-fusion quality metrics exactly as the VIFB benchmark computes them (Zhang, Ye, Xiao,
// "VIFB: A Visible and Infrared Image Fusion Benchmark", CVPRW 2020; MATLAB files
// metrics/metrics*.m), quirks included, so that values can be compared with VIFB's published
// tables:
//  - every metric is called as (visible, infrared, fused);
//  - colour images are scored per channel and the channel scores averaged (the infrared channel
//    k goes with colour channel k; a one-channel infrared goes with every channel);
//  - PSNR and RMSE use VIFB's "mse" = sqrt(sum((X - F)^2)) / (M N) (VIFB issue #15), hence PSNR
//    near 58 dB;
//  - MI uses natural logarithms and min-max rescaling of each image to 256 bins;
//  - SSIM is SSIM(VI, F) + SSIM(IR, F) (maximum 2), 11x11 Gaussian window, sigma 1.5, 'valid';
//  - SD is the population standard deviation;
//  - SF of a colour image runs over the three channels laid side by side (R | G | B), as MATLAB's
//    two-output size() makes it;
//  - Qabf uses atan (not atan2), zero-padded Sobel and all three images scaled by 255 the way
//    VIFB's im2double on double data leaves them;
//  - Qcv is lower-is-better and its complex value is reduced to the real part; Qcb and Qcv
//    min-max normalise each image to 0..255 first.
//
// Pixel formats: every image is CV_8UC1 or CV_8UC3 in OpenCV's BGR order, all of one size. The
// fused image and the visible image have the same channel count, or the fused image is one
// channel (then colour sources are converted with MATLAB's rgb2gray, rounded to 8 bits). The
// infrared image has one channel or as many as the fused image.
#include <array>
#include <optional>
#include <string>
#include <string_view>

#include <opencv2/core/mat.hpp>

namespace thermovis::metrics {

enum class Metric { CE, EN, MI, PSNR, AG, EI, Qabf, SD, SF, RMSE, SSIM, Qcb, Qcv };
inline constexpr std::size_t kMetricCount = 13;

// VIFB's names, in VIFB's table order: CE EN MI PSNR AG EI Qabf SD SF RMSE SSIM Qcb Qcv.
const std::array<Metric, kMetricCount>& all_metrics();
std::string_view metric_name(Metric metric);
std::optional<Metric> metric_from_name(std::string_view name);
// CE, RMSE and Qcv are lower-is-better; all others higher-is-better.
bool higher_is_better(Metric metric);

// One value per metric, indexed by Metric.
struct MetricValues {
  std::array<double, kMetricCount> value{};
  double& operator[](Metric m) { return value[static_cast<std::size_t>(m)]; }
  double operator[](Metric m) const { return value[static_cast<std::size_t>(m)]; }
};

// One metric of a fused image. Throws std::invalid_argument on empty images, unsupported types
// or channel counts, or sizes that differ.
double vifb_metric(Metric metric, const cv::Mat& visible, const cv::Mat& infrared,
                   const cv::Mat& fused);

// All 13 metrics.
MetricValues vifb_metrics(const cv::Mat& visible, const cv::Mat& infrared, const cv::Mat& fused);

// VIFB's evaluation protocol: the fused image is written as a JPEG of the given quality (MATLAB's
// imwrite default 75, libjpeg with 4:2:0 chroma subsampling) and decoded again before scoring.
cv::Mat jpeg_round_trip(const cv::Mat& image, int quality = 75);

}  // namespace thermovis::metrics
