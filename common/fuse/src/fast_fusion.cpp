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

// Bilinear resize into `out` (whose buffer is reused when its size matches).
void enlarge(const cv::Mat& m, cv::Size full, cv::Mat& out) {
  cv::resize(m, out, full, 0, 0, cv::INTER_LINEAR);
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

void fast_fuse(const cv::Mat& infrared, const std::vector<cv::Mat>& visible,
               const cv::Mat& decision_visible, std::vector<cv::Mat>& out,
               const FastFusionParams& p) {
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

  const int base_radius = std::max(0, static_cast<int>(std::lround((p.base_box_px / 2) / s)));
  const cv::Mat ir_base = box_mean(ir_small, base_radius);

  // Full-resolution maps are interpolated on the fly: each reduced map is first stretched to the
  // full width (cv::resize, INTER_LINEAR), then blended between two such rows per output row with
  // cv::resize's pixel-centre convention, inside the final loop.
  const cv::Size wide(full.width, small.height);
  const double row_scale = static_cast<double>(small.height) / full.height;
  std::vector<int> row0(static_cast<std::size_t>(full.height)), row1(row0.size());
  std::vector<float> row_t(row0.size());
  for (int r = 0; r < full.height; ++r) {
    const double y = std::max(0.0, (r + 0.5) * row_scale - 0.5);
    const int y0 = std::min(static_cast<int>(y), small.height - 1);
    row0[static_cast<std::size_t>(r)] = y0;
    row1[static_cast<std::size_t>(r)] = std::min(y0 + 1, small.height - 1);
    row_t[static_cast<std::size_t>(r)] = static_cast<float>(y - y0);
  }
  // Per-thread buffers of the stretched maps, reused from call to call.
  thread_local cv::Mat a_wide, b_wide, offset_wide, diff_wide, row;
  enlarge(a, wide, a_wide);
  enlarge(b, wide, b_wide);

  out.resize(visible.size());
  for (std::size_t k = 0; k < visible.size(); ++k) {
    const cv::Mat& vis = visible[k];
    const cv::Mat vs = vis.data == decision_visible.data ? vis_small : reduce(vis, small);
    const cv::Mat base_diff = ir_base - box_mean(vs, base_radius);  // B_ir - B_vis
    enlarge(base_weight.mul(base_diff), wide, offset_wide);
    enlarge(base_diff, wide, diff_wide);
    cv::Mat& fused = out[k];
    fused.create(full, CV_8UC1);
    // The row is computed in float (a loop the compiler vectorises: no uchar store that could
    // alias the inputs), then rounded and saturated to 8 bits by OpenCV.
    row.create(1, full.width, CV_32F);
    float* out_row = row.ptr<float>();
    for (int r = 0; r < full.height; ++r) {
      const auto i = static_cast<std::size_t>(r);
      const float t = row_t[i];
      const float* a0 = a_wide.ptr<float>(row0[i]);
      const float* a1 = a_wide.ptr<float>(row1[i]);
      const float* b0 = b_wide.ptr<float>(row0[i]);
      const float* b1 = b_wide.ptr<float>(row1[i]);
      const float* f0 = offset_wide.ptr<float>(row0[i]);
      const float* f1 = offset_wide.ptr<float>(row1[i]);
      const float* d0 = diff_wide.ptr<float>(row0[i]);
      const float* d1 = diff_wide.ptr<float>(row1[i]);
      const uchar* ir = infrared.ptr<uchar>(r);
      const uchar* vi = vis.ptr<uchar>(r);
      for (int c = 0; c < full.width; ++c) {
        const float g = static_cast<float>(ir[c]) * (1.0f / 255.0f);
        const float v = static_cast<float>(vi[c]) * (1.0f / 255.0f);
        const float ca = a0[c] + t * (a1[c] - a0[c]);
        const float cb = b0[c] + t * (b1[c] - b0[c]);
        const float fb = f0[c] + t * (f1[c] - f0[c]);
        const float bd = d0[c] + t * (d1[c] - d0[c]);
        const float w = std::min(std::max(ca * g + cb, 0.0f), 1.0f);
        // F = B_vis + W_B (B_ir - B_vis) + D_vis + W_D (D_ir - D_vis), with D = I - B.
        out_row[c] = v + fb + w * ((g - v) - bd);
      }
      cv::Mat fused_row = fused.row(r);
      row.convertTo(fused_row, CV_8U, 255.0);
    }
  }
}

std::vector<cv::Mat> fast_fuse(const cv::Mat& infrared, const std::vector<cv::Mat>& visible,
                               const cv::Mat& decision_visible, const FastFusionParams& params) {
  std::vector<cv::Mat> fused;
  fast_fuse(infrared, visible, decision_visible, fused, params);
  return fused;
}

}  // namespace thermovis::fuse
