#include "thermovis/fuse/vsmwls.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::fuse {
namespace {

// Sum over the (2r+1)^2 window, zero outside the image (boxfilter.m's clipped window).
cv::Mat box_sum(const cv::Mat& m, int r) {
  cv::Mat out;
  cv::boxFilter(m, out, CV_64F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false,
                cv::BORDER_CONSTANT);
  return out;
}

// fspecial('gaussian', side, sigma) applied by imfilter with the given border.
cv::Mat gaussian(const cv::Mat& input, int side, double sigma, int border) {
  const cv::Mat k = cv::getGaussianKernel(side, sigma, CV_64F);
  cv::Mat out;
  cv::sepFilter2D(input, out, CV_64F, k, k, cv::Point(-1, -1), 0.0, border);
  return out;
}

}  // namespace

VsmWlsParams VsmWlsParams::paper() {
  VsmWlsParams p;
  p.wls_window_sum = true;
  p.wls_epsilon = 1e-4;
  p.smooth_finest_weights = true;
  return p;
}

cv::Mat guided_filter(const cv::Mat& guide, const cv::Mat& input, int radius, double eps) {
  const cv::Mat count = box_sum(cv::Mat::ones(guide.size(), CV_64F), radius);
  const auto mean = [&](const cv::Mat& m) {
    cv::Mat out;
    cv::divide(box_sum(m, radius), count, out);
    return out;
  };
  const cv::Mat mean_i = mean(guide);
  const cv::Mat mean_p = mean(input);
  const cv::Mat cov_ip = mean(guide.mul(input)) - mean_i.mul(mean_p);
  const cv::Mat var_i = mean(guide.mul(guide)) - mean_i.mul(mean_i);
  cv::Mat a;
  cv::divide(cov_ip, var_i + eps, a);
  const cv::Mat b = mean_p - a.mul(mean_i);
  return mean(a).mul(guide) + mean(b);
}

cv::Mat gaussian_replicate(const cv::Mat& input, double sigma) {
  // gaussFilter.m: window = double(uint8(3 sigma) * 2 + 1); uint8() rounds half away from zero.
  const int side = 2 * static_cast<int>(std::round(3.0 * sigma)) + 1;
  return gaussian(input, side, sigma, cv::BORDER_REPLICATE);
}

cv::Mat rolling_guidance_guided(const cv::Mat& input, double sigma_spatial, double sigma_range,
                                int iterations) {
  cv::Mat result = gaussian_replicate(input, sigma_spatial);
  const int radius = static_cast<int>(sigma_spatial);
  for (int i = 0; i < iterations; ++i) {
    result = guided_filter(result, input, radius, sigma_range * sigma_range);
  }
  return result;
}

cv::Mat visual_saliency_map(const cv::Mat& input) {
  std::vector<int> level(input.total());
  std::array<double, 256> hist{};
  std::size_t n = 0;
  for (int r = 0; r < input.rows; ++r) {
    const auto* p = input.ptr<double>(r);
    for (int c = 0; c < input.cols; ++c, ++n) {
      // uint8(255 I): round half away from zero, saturate.
      const int g = static_cast<int>(std::clamp(std::round(255.0 * p[c]), 0.0, 255.0));
      level[n] = g;
      hist[static_cast<std::size_t>(g)] += 1.0;
    }
  }
  std::array<double, 256> table{};
  for (int v = 0; v < 256; ++v) {
    double s = 0.0;
    for (int i = 0; i < 256; ++i) s += hist[static_cast<std::size_t>(i)] * std::abs(v - i);
    table[static_cast<std::size_t>(v)] = s;
  }
  double lo = table[static_cast<std::size_t>(level[0])], hi = lo;
  for (int g : level) {
    lo = std::min(lo, table[static_cast<std::size_t>(g)]);
    hi = std::max(hi, table[static_cast<std::size_t>(g)]);
  }
  cv::Mat out(input.size(), CV_64F);
  n = 0;
  for (int r = 0; r < out.rows; ++r) {
    auto* d = out.ptr<double>(r);
    for (int c = 0; c < out.cols; ++c, ++n) {
      d[c] = hi > lo ? (table[static_cast<std::size_t>(level[n])] - lo) / (hi - lo) : 0.0;
    }
  }
  return out;
}

namespace {

// Detail layers d(1..levels) and the base layer (last entry) of one input.
std::vector<cv::Mat> decompose(const cv::Mat& input, const VsmWlsParams& p) {
  std::vector<cv::Mat> layers;
  cv::Mat previous = input;
  double sigma = p.sigma_spatial;
  for (int i = 1; i < p.levels; ++i) {
    cv::Mat next = rolling_guidance_guided(previous, sigma, p.sigma_range, p.rgf_iterations);
    layers.push_back(previous - next);
    previous = next;
    sigma *= 2.0;
  }
  const cv::Mat base = gaussian_replicate(previous, p.sigma_spatial);
  layers.push_back(previous - base);
  layers.push_back(base);
  return layers;
}

// Solve_Optimal.m's diagonal system in closed form: D = (M + lambda A d1) / (1 + lambda A),
// A = 1 / (|window(d2)| + epsilon), window = mean (code) or sum (paper) with 'replicate' border.
cv::Mat wls_detail(const cv::Mat& m, const cv::Mat& d1, const cv::Mat& d2, const VsmWlsParams& p) {
  cv::Mat window;
  cv::boxFilter(d2, window, CV_64F, cv::Size(p.wls_window, p.wls_window), cv::Point(-1, -1),
                !p.wls_window_sum, cv::BORDER_REPLICATE);
  cv::Mat out(m.size(), CV_64F);
  for (int r = 0; r < m.rows; ++r) {
    const auto* mm = m.ptr<double>(r);
    const auto* a1 = d1.ptr<double>(r);
    const auto* w = window.ptr<double>(r);
    auto* o = out.ptr<double>(r);
    for (int c = 0; c < m.cols; ++c) {
      const double la = p.lambda / (std::abs(w[c]) + p.wls_epsilon);
      o[c] = (mm[c] + la * a1[c]) / (1.0 + la);
    }
  }
  return out;
}

// C = [|d1| < |d2|] (ties to d1), optionally smoothed; M = C d2 + (1 - C) d1.
cv::Mat max_absolute(const cv::Mat& d1, const cv::Mat& d2, bool smooth, const VsmWlsParams& p) {
  cv::Mat choose2;
  cv::compare(cv::abs(d1), cv::abs(d2), choose2, cv::CMP_LT);
  cv::Mat c;
  choose2.convertTo(c, CV_64F, 1.0 / 255.0);
  if (smooth) {
    const int w = static_cast<int>(std::floor(3.0 * p.weight_sigma));
    c = gaussian(c, 2 * w + 1, p.weight_sigma, cv::BORDER_REFLECT);  // MATLAB 'symmetric'
  }
  return c.mul(d2) + (1.0 - c).mul(d1);
}

}  // namespace

cv::Mat vsmwls_fuse(const cv::Mat& i1, const cv::Mat& i2, const VsmWlsParams& p) {
  if (i1.type() != CV_64FC1 || i2.type() != CV_64FC1) {
    throw std::invalid_argument("vsmwls_fuse needs CV_64FC1 planes");
  }
  if (i1.size() != i2.size()) throw std::invalid_argument("vsmwls_fuse: planes differ in size");
  if (i1.rows < 18 || i1.cols < 18) {
    throw std::invalid_argument("VSM-WLS needs images of at least 18x18 pixels");
  }
  if (p.levels < 2) throw std::invalid_argument("VSM-WLS needs at least 2 levels");
  const auto l1 = decompose(i1, p);
  const auto l2 = decompose(i2, p);
  const std::size_t base = static_cast<std::size_t>(p.levels);

  const cv::Mat v1 = visual_saliency_map(i1);
  const cv::Mat v2 = visual_saliency_map(i2);
  cv::Mat fused = (0.5 + 0.5 * (v1 - v2)).mul(l1[base]) + (0.5 + 0.5 * (v2 - v1)).mul(l2[base]);

  fused += max_absolute(l1[0], l2[0], p.smooth_finest_weights, p);
  for (std::size_t i = base - 1; i >= 1; --i) {
    const cv::Mat m = max_absolute(l1[i], l2[i], true, p);
    fused += wls_detail(m, l1[i], l2[i], p);
  }
  return fused;
}

}  // namespace thermovis::fuse
