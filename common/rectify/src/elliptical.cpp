#include "thermovis/rectify/elliptical.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace thermovis::rectify {

namespace {

struct Sample {
  double x, y;    // corrected offset from the centre, px
  double r;       // Eq. 21
  double tx, ty;  // target raw offset, px
};

// Least squares for (p, q) = (1 / k2, k1 / k2) at fixed R: raw = (x, y) (p + q (r - R)^2).
// Returns the sum of squared residuals.
// The first sample is the side edge's midpoint (x = a, y = 0), held by a heavy weight: the
// corrected image's side edges stay at the raw image's, so the whole width is kept.
double solve_linear(const std::vector<Sample>& samples, double R, double& p, double& q) {
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    const double weight = i == 0 ? 1e6 : 1.0;
    const double d2 = (s.r - R) * (s.r - R);
    for (const auto& [coord, target] : {std::pair{s.x, s.tx}, std::pair{s.y, s.ty}}) {
      const Eigen::Vector2d row(coord, coord * d2);
      normal += weight * row * row.transpose();
      rhs += weight * row * target;
    }
  }
  const Eigen::Vector2d sol = normal.ldlt().solve(rhs);
  p = sol(0);
  q = sol(1);
  double sse = 0.0;
  for (const Sample& s : samples) {
    const double scale = p + q * (s.r - R) * (s.r - R);
    sse += std::pow(s.x * scale - s.tx, 2) + std::pow(s.y * scale - s.ty, 2);
  }
  return sse;
}

}  // namespace

EllipticalFit fit_elliptical_model(const camera::TaylorCamera& camera) {
  const cv::Size size = camera.image_size();
  const double a = size.width / 2.0, b = size.height / 2.0;
  const double cx = (size.width - 1) / 2.0, cy = (size.height - 1) / 2.0;
  const double phi_a = camera.field_angle_at_radius(a);
  if (!(phi_a > 0.0 && phi_a < M_PI / 2)) {
    throw std::invalid_argument(
        "elliptical model: the lens's field at the image's side edges is not between 0 and 90 "
        "deg, so no pinhole target exists");
  }
  EllipticalFit fit;
  fit.model.image_size = size;
  fit.target_f_px = a / std::tan(phi_a);
  std::vector<Sample> samples{{a, 0.0, 1.0, a, 0.0}};
  for (int v = 0; v < size.height; v += 8) {
    for (int u = 0; u < size.width; u += 8) {
      const double x = u - cx, y = v - cy;
      // Target: the ray of the pinhole, through the lens's radial function.
      const double X = x / fit.target_f_px, Y = y / fit.target_f_px;
      const double t = std::hypot(X, Y);
      const double phi = std::atan(t);
      if (phi >= camera.max_field_angle()) continue;
      const double rho = camera.radius_at_field_angle(phi);
      // Only where the target sees the raw image: beyond it there is nothing to correct.
      if (std::abs(X / t * rho) > a || std::abs(Y / t * rho) > b) continue;
      const double tx = t > 0.0 ? X / t * rho : 0.0, ty = t > 0.0 ? Y / t * rho : 0.0;
      samples.push_back({x, y, std::sqrt(x * x / (a * a) + y * y / (b * b)), tx, ty});
    }
  }
  // R by a scan and golden-section refinement; (k1, k2) by linear least squares at each R.
  double best_R = 0.0, best_sse = std::numeric_limits<double>::infinity(), p = 1.0, q = 0.0;
  for (double R = -3.0; R <= 6.0; R += 0.05) {
    const double sse = solve_linear(samples, R, p, q);
    if (sse < best_sse) {
      best_sse = sse;
      best_R = R;
    }
  }
  double lo = best_R - 0.05, hi = best_R + 0.05;
  const double golden = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int i = 0; i < 60; ++i) {
    const double m1 = hi - golden * (hi - lo), m2 = lo + golden * (hi - lo);
    if (solve_linear(samples, m1, p, q) < solve_linear(samples, m2, p, q)) {
      hi = m2;
    } else {
      lo = m1;
    }
  }
  fit.model.R = (lo + hi) / 2.0;
  best_sse = solve_linear(samples, fit.model.R, p, q);
  if (!(p > 0.0)) throw std::invalid_argument("elliptical model: fit gave a non-positive scale");
  fit.model.k2 = 1.0 / p;
  fit.model.k1 = q / p;
  fit.samples = static_cast<int>(samples.size());
  fit.rms_px = std::sqrt(best_sse / std::max<std::size_t>(1, samples.size()));
  for (const Sample& s : samples) {
    const double scale = p + q * (s.r - fit.model.R) * (s.r - fit.model.R);
    fit.max_px = std::max(fit.max_px, std::hypot(s.x * scale - s.tx, s.y * scale - s.ty));
  }
  return fit;
}

cv::Point2d elliptical_source(const EllipticalModel& m, double u, double v) {
  const double a = m.image_size.width / 2.0, b = m.image_size.height / 2.0;
  const double cx = (m.image_size.width - 1) / 2.0, cy = (m.image_size.height - 1) / 2.0;
  const double x = u - cx, y = v - cy;
  const double r = std::sqrt(x * x / (a * a) + y * y / (b * b));
  const double scale = (1.0 + m.k1 * (r - m.R) * (r - m.R)) / m.k2;
  return {cx + x * scale, cy + y * scale};
}

cv::Mat build_elliptical_map(const EllipticalModel& m) {
  const int w = m.image_size.width, h = m.image_size.height;
  if (w <= 0 || h <= 0 || !(m.k2 != 0.0) || !std::isfinite(m.k1) || !std::isfinite(m.R)) {
    throw std::invalid_argument("elliptical model: empty image size or invalid k1, k2, R");
  }
  cv::Mat map(m.image_size, CV_32FC2);
  for (int v = 0; v < h; ++v) {
    const int v_rep = std::min(v, h - 1 - v);
    auto* row = map.ptr<cv::Vec2f>(v);
    for (int u = 0; u < w; ++u) {
      const int u_rep = std::min(u, w - 1 - u);
      // The representative in the top-left quadrant, mirrored.
      // Positions on a 2^-13 px grid: then both a position and its mirror (w - 1) - x are exact
      // floats (below 2048 px), and the fixed-point table is exactly symmetric.
      const cv::Point2d p = elliptical_source(m, u_rep, v_rep);
      double x = std::ldexp(std::round(std::ldexp(p.x, 13)), -13);
      double y = std::ldexp(std::round(std::ldexp(p.y, 13)), -13);
      if (u != u_rep) x = (w - 1) - x;
      if (v != v_rep) y = (h - 1) - y;
      row[u] = cv::Vec2f(static_cast<float>(x), static_cast<float>(y));
    }
  }
  return map;
}

}  // namespace thermovis::rectify
