#include "thermovis/match/region_align.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::match {

namespace {

constexpr util::EnumName<RegionStatus> kRegionStatusNames[] = {
    {RegionStatus::ok, "ok"},
    {RegionStatus::empty_region, "empty_region"},
    {RegionStatus::at_image_edge, "at_image_edge"},
    {RegionStatus::flat, "flat"},
    {RegionStatus::ambiguous, "ambiguous"},
    {RegionStatus::low_correlation, "low_correlation"},
    {RegionStatus::no_convergence, "no_convergence"},
    {RegionStatus::not_aligned, "not_aligned"}};

}  // namespace

std::string region_status_name(RegionStatus status) {
  return util::name_of(kRegionStatusNames, status, "unknown");
}

namespace {

struct Pixel {
  int x, y;
  float value;
  bool contour;  // within the contour band of the outline
  bool ring;     // just outside the mask (the outline's other side)
};

// Catmull-Rom weights for the fraction t of the taps at -1, 0, 1, 2, and their derivatives.
void catmull_rom(double t, double w[4], double dw[4]) {
  const double t2 = t * t, t3 = t2 * t;
  w[0] = 0.5 * (-t3 + 2 * t2 - t);
  w[1] = 0.5 * (3 * t3 - 5 * t2 + 2);
  w[2] = 0.5 * (-3 * t3 + 4 * t2 + t);
  w[3] = 0.5 * (t3 - t2);
  dw[0] = 0.5 * (-3 * t2 + 4 * t - 1);
  dw[1] = 0.5 * (9 * t2 - 10 * t);
  dw[2] = 0.5 * (-9 * t2 + 8 * t + 1);
  dw[3] = 0.5 * (3 * t2 - 2 * t);
}

// Separable Catmull-Rom sampling of R at every region pixel shifted by one (-d, dy): the
// fraction of the shift, and so the 4 x 4 weights, are the same for all pixels.
class ShiftedSampler {
 public:
  ShiftedSampler(const cv::Mat& R, double d, double dy) : R_(R) {
    const double u = -d, v = dy, fu = std::floor(u), fv = std::floor(v);
    ox_ = static_cast<int>(fu) - 1;
    oy_ = static_cast<int>(fv) - 1;
    catmull_rom(u - fu, wx_, dwx_);
    catmull_rom(v - fv, wy_, dwy_);
  }
  // R and its derivatives along x and y at (x - d, y + dy); false when the 4 x 4 taps leave the
  // image.
  bool operator()(int x, int y, double& value, double& du, double& dv) const {
    const int ix = x + ox_, iy = y + oy_;
    if (ix < 0 || iy < 0 || ix + 3 >= R_.cols || iy + 3 >= R_.rows) return false;
    const uchar* row = R_.ptr<uchar>(iy) + ix;
    const size_t step = R_.step[0];
    double value_ = 0, du_ = 0, dv_ = 0;
    for (int j = 0; j < 4; ++j, row += step) {
      const double r0 = row[0], r1 = row[1], r2 = row[2], r3 = row[3];
      const double s = wx_[0] * r0 + wx_[1] * r1 + wx_[2] * r2 + wx_[3] * r3;
      const double sd = dwx_[0] * r0 + dwx_[1] * r1 + dwx_[2] * r2 + dwx_[3] * r3;
      value_ += wy_[j] * s;
      du_ += wy_[j] * sd;
      dv_ += dwy_[j] * s;
    }
    value = value_;
    du = du_;
    dv = dv_;
    return true;
  }

 private:
  const cv::Mat& R_;
  int ox_, oy_;
  double wx_[4], dwx_[4], wy_[4], dwy_[4];
};

// ZNCC of the region's left values (with or without the ring around the mask) with the right
// image at integer shift (d, dy); -2 when a pixel leaves the right image.
double zncc_shift(const std::vector<Pixel>& pixels, const cv::Mat& R, int d, int dy,
                  bool with_ring) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0, n = 0;
  for (const Pixel& p : pixels) {
    if (p.ring && !with_ring) continue;
    const int x = p.x - d, y = p.y + dy;
    if (x < 0 || y < 0 || x >= R.cols || y >= R.rows) return -2.0;
    const double a = p.value, b = R.at<uchar>(y, x);
    sa += a;
    sb += b;
    saa += a * a;
    sbb += b * b;
    sab += a * b;
    n += 1;
  }
  if (n < 2) return 0.0;
  const double var = (saa - sa * sa / n) * (sbb - sb * sb / n);
  return var > 1e-9 ? (sab - sa * sb / n) / std::sqrt(var) : 0.0;
}

// The correlation without the ring must beat the one with it by this much to drop the ring.
constexpr double kRingMargin = 0.02;
// A smaller mask always keeps its ring: alone its few pixels (a far target's) align worse than
// with a background they partly share.
constexpr int kRingDropMinPixels = 100;

RegionDisparity fail(RegionDisparity r, RegionStatus status, std::string message) {
  r.status = status;
  r.message = std::move(message);
  r.disparity_px = r.sigma_px = RegionDisparity::nan;
  return r;
}

double median_of(std::vector<double> v) {
  if (v.empty()) return 0.0;
  auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

RegionDisparity align_region(const cv::Mat& L, const cv::Mat& R, const cv::Rect& box,
                             const cv::Mat& mask, double initial_disparity_px,
                             const RegionOptions& o) {
  if (L.type() != CV_8UC1 || R.type() != CV_8UC1 || L.size() != R.size() || L.empty()) {
    throw std::invalid_argument("align_region: the images must be 8-bit grey of one size");
  }
  if (!mask.empty() && (mask.type() != CV_8UC1 || mask.size() != box.size())) {
    throw std::invalid_argument("align_region: the mask must be 8-bit of the box's size");
  }
  if (!(o.max_disparity_px >= o.min_disparity_px)) {
    throw std::invalid_argument("align_region: max_disparity_px < min_disparity_px");
  }
  RegionDisparity r;
  const cv::Rect inside = box & cv::Rect(0, 0, L.cols, L.rows);
  if (inside.empty()) {
    return fail(r, RegionStatus::empty_region, "the region has no area inside the image");
  }
  if (inside != box) {
    // Part of the target is beyond the image: its outline there is the image's edge, which
    // does not move with the target.
    return fail(r, RegionStatus::at_image_edge,
                "the region is cut by the image edge (box x " + std::to_string(box.x) + ".." +
                    std::to_string(box.br().x - 1) + ", y " + std::to_string(box.y) + ".." +
                    std::to_string(box.br().y - 1) + ", image " + std::to_string(L.cols) + " x " +
                    std::to_string(L.rows) + ")");
  }
  // The region's mask on `inside`, padded by one pixel of zeros so that its outline is found
  // also where it touches the box.
  cv::Mat region(inside.height + 2, inside.width + 2, CV_8UC1, cv::Scalar(0));
  if (mask.empty()) {
    region(cv::Rect(1, 1, inside.width, inside.height)).setTo(255);
  } else {
    cv::Mat in = mask(cv::Rect(inside.tl() - box.tl(), inside.size()));
    cv::Mat roi = region(cv::Rect(1, 1, inside.width, inside.height));
    cv::compare(in, 0, roi, cv::CMP_GT);
  }
  const int count = cv::countNonZero(region);
  if (count == 0) return fail(r, RegionStatus::empty_region, "the region's mask has no pixel set");
  cv::Mat to_outline;
  cv::distanceTransform(region, to_outline, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  // The one-pixel ring just outside the mask: the outline's other side, whose brightness the
  // outline's position sets too (a uniform body correlates only through its outline). It counts
  // options.ring_weight in the refinement and is not part of the region's pixels or anchor.
  cv::Mat ring;
  if (!mask.empty()) {
    cv::dilate(region, ring, cv::getStructuringElement(cv::MORPH_RECT, {3, 3}));
    ring &= ~region;
  } else {
    ring = cv::Mat::zeros(region.size(), CV_8UC1);
  }
  const int stride = std::max(
      1, static_cast<int>(std::ceil(std::sqrt(double(count) / std::max(1, o.max_pixels)))));
  std::vector<Pixel> pixels;
  pixels.reserve(
      static_cast<size_t>(count / (stride * stride) + 2 * (inside.width + inside.height)));
  double cx = 0, cy = 0, gradient1 = 0, gradient2 = 0;
  int gradient_n = 0, in_mask = 0;
  for (int y = -1; y <= inside.height; ++y) {
    for (int x = -1; x <= inside.width; ++x) {
      const bool in = region.at<uchar>(y + 1, x + 1) != 0,
                 around = ring.at<uchar>(y + 1, x + 1) != 0;
      if (!in && !around) continue;
      // The ring is a line: on the same lattice it keeps its share of the pixels.
      if (x % stride != 0 || y % stride != 0) continue;
      const int gx = inside.x + x, gy = inside.y + y;
      if (gx < 0 || gy < 0 || gx >= L.cols || gy >= L.rows) continue;
      pixels.push_back({gx, gy, static_cast<float>(L.at<uchar>(gy, gx)),
                        in && to_outline.at<float>(y + 1, x + 1) <= o.contour_band_px + 0.5, !in});
      if (gx > 0 && gx + 1 < L.cols) {
        const double g = 0.5 * (double(L.at<uchar>(gy, gx + 1)) - L.at<uchar>(gy, gx - 1));
        gradient1 += g;
        gradient2 += g * g;
        ++gradient_n;
      }
      if (!in) continue;
      ++in_mask;
      cx += gx;
      cy += gy;
    }
  }
  r.pixels = in_mask;
  r.anchor = {cx / std::max(1, in_mask), cy / std::max(1, in_mask)};
  // The horizontal gradient's spread about its mean: a brightness ramp across the region (a
  // sky, a lit wall) moves like an offset when shifted and tells nothing of the disparity.
  const double mean_gradient = gradient_n ? gradient1 / gradient_n : 0.0;
  const double rms_gradient =
      gradient_n ? std::sqrt(std::max(0.0, gradient2 / gradient_n - mean_gradient * mean_gradient))
                 : 0.0;
  if (pixels.size() < 6 || rms_gradient < o.min_gradient) {
    return fail(r, RegionStatus::flat,
                "the region is flat: horizontal gradient spread " + std::to_string(rms_gradient) +
                    " grey levels/px over " + std::to_string(pixels.size()) + " px (" +
                    std::to_string(o.min_gradient) + " needed)");
  }

  // Integer start: the peak of the whole region's correlation along the row.
  int lo = static_cast<int>(std::floor(o.min_disparity_px));
  int hi = static_cast<int>(std::ceil(o.max_disparity_px));
  if (std::isfinite(initial_disparity_px)) {
    const int d0 = static_cast<int>(std::lround(initial_disparity_px));
    lo = std::max(lo, d0 - o.search_radius_px);
    hi = std::min(hi, d0 + o.search_radius_px);
    if (lo > hi) lo = hi = std::clamp(d0, lo, hi);
  }
  // The row offset the epipolar geometry expects at disparity d.
  const auto row_at = [&](double d) { return o.row_offset_px + o.row_offset_per_disparity * d; };
  // The ring moves with the outline only where the background behind is plain; behind a
  // textured background it moves with the background. Both ways are correlated and the better
  // one kept: without the ring, its pixels are dropped.
  const bool has_ring = static_cast<int>(pixels.size()) > in_mask;
  r.ring_used = has_ring;
  std::vector<double> c(static_cast<size_t>(hi - lo + 1)), c_mask;
  for (int d = lo; d <= hi; ++d) {
    c[static_cast<size_t>(d - lo)] =
        zncc_shift(pixels, R, d, static_cast<int>(std::lround(row_at(d))), true);
  }
  if (has_ring && in_mask >= kRingDropMinPixels) {
    c_mask.resize(c.size());
    for (int d = lo; d <= hi; ++d) {
      c_mask[static_cast<size_t>(d - lo)] =
          zncc_shift(pixels, R, d, static_cast<int>(std::lround(row_at(d))), false);
    }
    if (*std::max_element(c_mask.begin(), c_mask.end()) >
        *std::max_element(c.begin(), c.end()) + kRingMargin) {
      c.swap(c_mask);
      pixels.erase(
          std::remove_if(pixels.begin(), pixels.end(), [](const Pixel& p) { return p.ring; }),
          pixels.end());
      r.ring_used = false;
    }
  }
  const auto best_it = std::max_element(c.begin(), c.end());
  const int best = static_cast<int>(best_it - c.begin());
  if (*best_it < -1.5) {
    return fail(r, RegionStatus::at_image_edge,
                "the region leaves the right image at every disparity searched");
  }
  double runner_up = -1.0;
  for (size_t k = 0; k < c.size(); ++k) {
    if (static_cast<int>(k) == best || c[k] < -1.5) continue;
    const bool left_ok = k == 0 || c[k] >= c[k - 1];
    const bool right_ok = k + 1 == c.size() || c[k] >= c[k + 1];
    const bool beside_best = std::abs(static_cast<int>(k) - best) <= 1;
    if (left_ok && right_ok && !beside_best) runner_up = std::max(runner_up, c[k]);
  }
  if (*best_it < o.min_zncc - 0.15) {
    return fail(r, RegionStatus::low_correlation,
                "the region's best correlation along the row is " + std::to_string(*best_it));
  }
  if (*best_it - runner_up < o.uniqueness) {
    return fail(r, RegionStatus::ambiguous,
                "two disparities correlate alike (" + std::to_string(*best_it) + " and " +
                    std::to_string(runner_up) + ")");
  }
  double d = lo + best;
  if (best > 0 && best + 1 < static_cast<int>(c.size()) && c[best - 1] > -1.5 &&
      c[best + 1] > -1.5) {
    const double denom = c[best - 1] - 2 * c[best] + c[best + 1];
    if (denom < 0) d += std::clamp(0.5 * (c[best - 1] - c[best + 1]) / denom, -0.5, 0.5);
  }

  // Gauss-Newton on (d, dy, g, h) to convergence with fixed weights, then the weights
  // recomputed from the residuals (Tukey): one plain pass and `robust_passes` reweighted ones.
  // The gain acts about the region's mean brightness, so that gain and offset stay decoupled.
  double dy = row_at(d), g = 1.0, h = 0.0;
  std::vector<double> prior(pixels.size(), 1.0);
  double mean_value = 0, prior_sum = 0;
  for (size_t i = 0; i < pixels.size(); ++i) {
    if (pixels[i].ring) prior[i] = o.ring_weight;
    mean_value += prior[i] * pixels[i].value;
    prior_sum += prior[i];
  }
  mean_value /= std::max(prior_sum, 1e-9);
  std::vector<double> weight = prior, residual(pixels.size(), 0.0), gradient(pixels.size(), 0.0);
  std::vector<char> valid(pixels.size(), 0);
  bool converged = false;
  constexpr int robust_passes = 3;
  for (int pass = 0; pass <= robust_passes; ++pass) {
    converged = false;
    for (int iteration = 0; iteration < o.max_iterations; ++iteration) {
      Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
      Eigen::Vector4d b = Eigen::Vector4d::Zero();
      int used = 0;
      const ShiftedSampler sample(R, d, dy);
      for (size_t i = 0; i < pixels.size(); ++i) {
        double v, du, dv;
        valid[i] = sample(pixels[i].x, pixels[i].y, v, du, dv);
        if (!valid[i]) continue;
        ++used;
        const double e = g * (v - mean_value) + h + mean_value - pixels[i].value;
        residual[i] = e;
        gradient[i] = g * std::sqrt(du * du + dv * dv);
        if (weight[i] == 0.0) continue;
        const Eigen::Vector4d J(-g * du, g * dv, v - mean_value, 1.0);
        H.noalias() += weight[i] * J * J.transpose();
        b.noalias() -= weight[i] * e * J;
      }
      if (used < 6) {
        return fail(r, RegionStatus::at_image_edge, "the aligned region leaves the right image");
      }
      // A weak prior holds the gain at 1 where the region's own contrast cannot fix it (a
      // uniformly warm body: only its outline varies): as strong as pixels spread by +-2 grey
      // levels, so that any textured region outweighs it.
      const double gain_prior = 4.0 * used;
      H(2, 2) += gain_prior;
      b(2) -= gain_prior * (g - 1.0);
      const Eigen::Vector4d step = H.ldlt().solve(b);
      if (!step.allFinite()) break;
      d += std::clamp(step[0], -1.0, 1.0);
      dy += std::clamp(step[1], -1.0, 1.0);
      g += step[2];
      h += step[3];
      if (!(d >= o.min_disparity_px - 1.0 && d <= o.max_disparity_px + 1.0) ||
          std::abs(dy - row_at(d)) > 3.0 || !(g > 0.2 && g < 5.0)) {
        return fail(r, RegionStatus::no_convergence,
                    "the alignment left the search range (d " + std::to_string(d) + " px, dy " +
                        std::to_string(dy) + " px, gain " + std::to_string(g) + ")");
      }
      // Settled when d moves by less than 2e-3 px. The row offset only has to hold still to
      // 0.01 px: it is not the result, and a far target's few rows fix it slowly.
      if (std::abs(step[0]) < 2e-3 && std::abs(step[1]) < 1e-2) {
        converged = true;
        break;
      }
    }
    if (!converged) break;
    if (pass == robust_passes) break;
    // Each pixel's residual scale: the noise (robust, from the residuals) and what a
    // misalignment of `position_tolerance_px` makes of its gradient, so that an outline pixel
    // (steep, the most informative) is not taken for an outlier before the fit has settled.
    std::vector<double> abs_e;
    abs_e.reserve(pixels.size());
    for (size_t i = 0; i < pixels.size(); ++i)
      if (valid[i] && prior[i] > 0) abs_e.push_back(std::abs(residual[i]));
    const double noise = std::max(0.5, 1.4826 * median_of(abs_e));
    for (size_t i = 0; i < pixels.size(); ++i) {
      if (!valid[i]) {
        weight[i] = 0.0;
        continue;
      }
      const double step = o.position_tolerance_px * gradient[i];
      const double u = residual[i] / (o.tukey_c * std::sqrt(noise * noise + step * step));
      weight[i] = std::abs(u) < 1.0 ? prior[i] * (1 - u * u) * (1 - u * u) : 0.0;
    }
  }
  if (!converged) {
    return fail(
        r, RegionStatus::no_convergence,
        "the alignment did not settle in " + std::to_string(o.max_iterations) + " iterations");
  }
  // Final statistics at the solution.
  double sw = 0, swe2 = 0, sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0, info = 0, info_contour = 0;
  Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
  const ShiftedSampler sample(R, d, dy);
  for (size_t i = 0; i < pixels.size(); ++i) {
    double v, du, dv;
    if (!sample(pixels[i].x, pixels[i].y, v, du, dv)) continue;
    const double e = g * (v - mean_value) + h + mean_value - pixels[i].value, w = weight[i];
    const Eigen::Vector4d J(-g * du, g * dv, v - mean_value, 1.0);
    H.noalias() += w * J * J.transpose();
    sw += w;
    swe2 += w * e * e;
    const double a = pixels[i].value;
    sa += w * a;
    sb += w * v;
    saa += w * a * a;
    sbb += w * v * v;
    sab += w * a * v;
    info += w * du * du;
    if (pixels[i].contour || pixels[i].ring) info_contour += w * du * du;
  }
  const double var = (saa - sa * sa / sw) * (sbb - sb * sb / sw);
  r.zncc = var > 1e-9 ? (sab - sa * sb / sw) / std::sqrt(var) : 0.0;
  r.disparity_px = d;
  r.row_offset_px = dy;
  r.gain = g;
  r.offset = h + mean_value * (1.0 - g);  // as in g R + offset
  r.contour_fraction = info > 0 ? info_contour / info : RegionDisparity::nan;
  if (r.zncc < o.min_zncc) {
    return fail(r, RegionStatus::low_correlation,
                "the aligned region correlates " + std::to_string(r.zncc) + " (" +
                    std::to_string(o.min_zncc) + " needed)");
  }
  const Eigen::Matrix4d cov = H.inverse();
  const double s2 = swe2 / std::max(1.0, sw - 4.0);
  r.sigma_px = std::sqrt(std::max(0.0, s2 * cov(0, 0)));
  if (!std::isfinite(r.sigma_px)) {
    return fail(r, RegionStatus::flat, "the alignment is degenerate (no information on d)");
  }
  r.status = RegionStatus::ok;
  return r;
}

cv::Mat target_silhouette(const cv::Mat& image, const cv::Rect& box) {
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1) {
    throw std::invalid_argument("target_silhouette: the image must be 8-bit or 16-bit grey");
  }
  const cv::Rect inside = box & cv::Rect(0, 0, image.cols, image.rows);
  if (inside.width < 3 || inside.height < 3) return {};
  cv::Mat grey;
  if (image.type() == CV_16UC1) {
    double lo = 0, hi = 0;
    cv::minMaxLoc(image(inside), &lo, &hi);
    if (hi - lo < 1) return {};
    image(inside).convertTo(grey, CV_8U, 255.0 / (hi - lo), -lo * 255.0 / (hi - lo));
  } else {
    grey = image(inside);
  }
  cv::Mat split;
  cv::threshold(grey, split, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  if (cv::countNonZero(split) == 0 || cv::countNonZero(split) == static_cast<int>(split.total()))
    return {};
  // The target's side fills the central part (middle half of the width and height) more than
  // the one-pixel border ring.
  const cv::Rect centre(inside.width / 4, inside.height / 4, std::max(1, inside.width / 2),
                        std::max(1, inside.height / 2));
  const double centre_bright = cv::countNonZero(split(centre)) / double(centre.area());
  cv::Mat ring = split.clone();
  ring(cv::Rect(1, 1, inside.width - 2, inside.height - 2)).setTo(0);
  const int ring_n = 2 * (inside.width + inside.height) - 4;
  const double ring_bright = cv::countNonZero(ring) / double(ring_n);
  if (centre_bright < ring_bright) cv::bitwise_not(split, split);
  const double share = cv::countNonZero(split) / double(split.total());
  if (share < 0.10 || share > 0.95) return {};
  cv::Mat out(box.size(), CV_8UC1, cv::Scalar(0));
  split.copyTo(out(cv::Rect(inside.tl() - box.tl(), inside.size())));
  return out;
}

}  // namespace thermovis::match
