#include "thermovis/fuse/fast_fusion.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace thermovis::fuse {
namespace {

cv::Mat box_mean(const cv::Mat& m, int radius) {
  cv::Mat out;
  const int side = 2 * std::max(radius, 0) + 1;
  cv::blur(m, out, cv::Size(side, side), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  return out;
}

// Guided-filter coefficients (q = a I + b) on the reduced grid.
void guided_coefficients(const cv::Mat& guide, const cv::Mat& input, int radius, double eps,
                         cv::Mat& a, cv::Mat& b) {
  const cv::Mat mean_i = box_mean(guide, radius);
  const cv::Mat mean_p = box_mean(input, radius);
  const cv::Mat cov = box_mean(guide.mul(input), radius) - mean_i.mul(mean_p);
  const cv::Mat var = box_mean(guide.mul(guide), radius) - mean_i.mul(mean_i);
  cv::divide(cov, var + eps, a);
  b = mean_p - a.mul(mean_i);
  a = box_mean(a, radius);
  b = box_mean(b, radius);
}

cv::Mat reduce(const cv::Mat& plane_u8, cv::Size small) {
  cv::Mat f;
  if (plane_u8.size() == small) {
    plane_u8.convertTo(f, CV_32F, 1.0 / 255.0);
    return f;
  }
  cv::Mat r;
  cv::resize(plane_u8, r, small, 0, 0, cv::INTER_AREA);
  r.convertTo(f, CV_32F, 1.0 / 255.0);
  return f;
}

cv::Mat enlarge(const cv::Mat& m, cv::Size full) {
  if (m.size() == full) return m;
  cv::Mat out;
  cv::resize(m, out, full, 0, 0, cv::INTER_LINEAR);
  return out;
}

cv::Mat saliency(const cv::Mat& plane, double sigma) {
  cv::Mat lap;
  cv::Laplacian(plane, lap, CV_32F, 1, 1.0, 0.0, cv::BORDER_REPLICATE);
  lap = cv::abs(lap);
  cv::Mat out;
  cv::GaussianBlur(lap, out, cv::Size(0, 0), std::max(sigma, 0.3), 0.0, cv::BORDER_REPLICATE);
  return out;
}

}  // namespace

std::vector<cv::Mat> fast_fuse(const cv::Mat& infrared, const std::vector<cv::Mat>& visible,
                               const cv::Mat& decision_visible, const FastFusionParams& p) {
  if (infrared.type() != CV_8UC1 || decision_visible.type() != CV_8UC1) {
    throw std::invalid_argument("fast_fuse needs CV_8UC1 planes");
  }
  if (p.scale < 1) throw std::invalid_argument("fast_fuse: scale must be >= 1");
  for (const auto& v : visible) {
    if (v.type() != CV_8UC1 || v.size() != infrared.size()) {
      throw std::invalid_argument("fast_fuse: visible planes must be CV_8UC1 of the infrared size");
    }
  }
  const cv::Size full = infrared.size();
  const cv::Size small((full.width + p.scale - 1) / p.scale, (full.height + p.scale - 1) / p.scale);
  const double s = static_cast<double>(full.width) / small.width;

  const cv::Mat ir_small = reduce(infrared, small);
  const cv::Mat vis_small = reduce(decision_visible, small);
  cv::Mat choose_ir;
  cv::compare(saliency(ir_small, p.saliency_sigma_px / s),
              saliency(vis_small, p.saliency_sigma_px / s), choose_ir, cv::CMP_GT);
  cv::Mat pmap;
  choose_ir.convertTo(pmap, CV_32F, 1.0 / 255.0);

  cv::Mat a, b;
  guided_coefficients(ir_small, pmap, static_cast<int>(std::lround(p.base_radius_px / s)),
                      p.base_eps, a, b);
  cv::Mat base_weight = a.mul(ir_small) + b;
  base_weight = cv::max(cv::min(base_weight, 1.0), 0.0);
  guided_coefficients(ir_small, pmap,
                      std::max(1, static_cast<int>(std::lround(p.detail_radius_px / s))),
                      p.detail_eps, a, b);
  const cv::Mat a_full = enlarge(a, full);
  const cv::Mat b_full = enlarge(b, full);

  const int base_radius = std::max(0, static_cast<int>(std::lround((p.base_box_px / 2) / s)));
  const cv::Mat ir_base = box_mean(ir_small, base_radius);

  std::vector<cv::Mat> out;
  for (const auto& vis : visible) {
    const cv::Mat vs = vis.data == decision_visible.data ? vis_small : reduce(vis, small);
    const cv::Mat vis_base = box_mean(vs, base_radius);
    // Base term minus the visible base, and the difference of the bases (intensities 0..1).
    const cv::Mat base_diff = ir_base - vis_base;
    const cv::Mat fused_base_offset = enlarge(base_weight.mul(base_diff), full);
    const cv::Mat base_diff_full = enlarge(base_diff, full);
    cv::Mat fused(full, CV_8UC1);
    for (int r = 0; r < full.height; ++r) {
      const uchar* ir = infrared.ptr<uchar>(r);
      const uchar* vi = vis.ptr<uchar>(r);
      const float* ca = a_full.ptr<float>(r);
      const float* cb = b_full.ptr<float>(r);
      const float* fb = fused_base_offset.ptr<float>(r);
      const float* bd = base_diff_full.ptr<float>(r);
      uchar* o = fused.ptr<uchar>(r);
      for (int c = 0; c < full.width; ++c) {
        const float g = ir[c] * (1.0f / 255.0f);
        const float v = vi[c] * (1.0f / 255.0f);
        const float w = std::clamp(ca[c] * g + cb[c], 0.0f, 1.0f);
        // F = B_vis + W_B (B_ir - B_vis) + D_vis + W_D (D_ir - D_vis), D = I - B.
        const float f = v + fb[c] + w * ((g - v) - bd[c]);
        o[c] = cv::saturate_cast<uchar>(f * 255.0f);
      }
    }
    out.push_back(fused);
  }
  return out;
}

}  // namespace thermovis::fuse
