#include "thermovis/match/stereo_match.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::match {

namespace {

constexpr util::EnumName<Method> kMethodNames[] = {{Method::orb, "orb"},
                                                   {Method::akaze, "akaze"},
                                                   {Method::sift, "sift"},
                                                   {Method::ncc, "ncc"},
                                                   {Method::sgbm, "sgbm"}};

}  // namespace

Method parse_method(const std::string& name) {
  if (const auto method = util::parse(kMethodNames, name)) return *method;
  throw std::invalid_argument("unknown matching method '" + name + "' (expected " +
                              util::join_names(kMethodNames, ", ", " or ") + ")");
}

std::string method_name(Method method) { return util::name_of(kMethodNames, method, "unknown"); }

std::vector<Method> all_methods() {
  std::vector<Method> methods;
  for (const auto& entry : kMethodNames) methods.push_back(entry.value);
  return methods;
}

namespace {

cv::Mat to_grey(const cv::Mat& image, const char* which) {
  if (image.empty())
    throw std::invalid_argument(std::string("match: ") + which + " image is empty");
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }
  throw std::invalid_argument(std::string("match: ") + which +
                              " image must be 8-bit with 1 or 3 channels (16-bit infrared needs "
                              "an AGC first), got type " +
                              std::to_string(image.type()));
}

// Zero-mean normalised cross-correlation of the (2r+1)^2 patches centred at integer pixels a
// (in A) and b (in B); both must be inside their images.
double zncc_at(const cv::Mat& A, cv::Point a, const cv::Mat& B, cv::Point b, int r) {
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (int dy = -r; dy <= r; ++dy) {
    const uchar* pa = A.ptr<uchar>(a.y + dy) + a.x - r;
    const uchar* pb = B.ptr<uchar>(b.y + dy) + b.x - r;
    for (int dx = 0; dx <= 2 * r; ++dx) {
      const double va = pa[dx], vb = pb[dx];
      sa += va;
      sb += vb;
      saa += va * va;
      sbb += vb * vb;
      sab += va * vb;
    }
  }
  const double n = (2 * r + 1) * (2 * r + 1);
  const double cov = sab - sa * sb / n;
  const double var = (saa - sa * sa / n) * (sbb - sb * sb / n);
  return var > 1e-9 ? cov / std::sqrt(var) : 0.0;
}

bool patch_inside(const cv::Mat& image, cv::Point p, int r) {
  return p.x - r >= 0 && p.y - r >= 0 && p.x + r < image.cols && p.y + r < image.rows;
}

// The ZNCC profile of one left patch along a row of the other image, over integer disparities
// [d_lo, d_hi]; positions whose patch leaves the image get -2. sign = +1: the other image is the
// right one (x - d), -1: it is the left one (x + d).
void zncc_profile(const cv::Mat& from, cv::Point p, const cv::Mat& to, int row, int d_lo, int d_hi,
                  int sign, int r, std::vector<double>& out) {
  out.assign(static_cast<size_t>(d_hi - d_lo + 1), -2.0);
  const int side = 2 * r + 1, n = side * side;
  // Zero-mean reference patch.
  float ref[31 * 31];
  double mean = 0;
  for (int dy = -r, k = 0; dy <= r; ++dy) {
    const uchar* pa = from.ptr<uchar>(p.y + dy) + p.x - r;
    for (int dx = 0; dx < side; ++dx, ++k) {
      ref[k] = pa[dx];
      mean += pa[dx];
    }
  }
  mean /= n;
  double ref_norm2 = 0;
  for (int k = 0; k < n; ++k) {
    ref[k] = static_cast<float>(ref[k] - mean);
    ref_norm2 += static_cast<double>(ref[k]) * ref[k];
  }
  if (ref_norm2 < 1e-6 || row - r < 0 || row + r >= to.rows) return;
  // Candidate patch centres in `to`: c(d) = p.x - sign * d, kept inside the image.
  const int c_a = p.x - sign * d_lo, c_b = p.x - sign * d_hi;
  const int c_min = std::max(std::min(c_a, c_b), r);
  const int c_max = std::min(std::max(c_a, c_b), to.cols - 1 - r);
  if (c_min > c_max) return;
  const int m = c_max - c_min + 1, span = m + 2 * r;
  // Cross terms for all centres at once: for each reference pixel, one multiply-add over the
  // contiguous run of candidate positions (vectorises), plus column sums for the window stats.
  thread_local std::vector<float> cross, buf, col_sum, col_sq;
  cross.assign(static_cast<size_t>(m), 0.f);
  col_sum.assign(static_cast<size_t>(span), 0.f);
  col_sq.assign(static_cast<size_t>(span), 0.f);
  buf.resize(static_cast<size_t>(span));
  for (int dy = -r; dy <= r; ++dy) {
    const uchar* src = to.ptr<uchar>(row + dy) + c_min - r;
    float* b = buf.data();
    for (int i = 0; i < span; ++i) {
      b[i] = src[i];
      col_sum[static_cast<size_t>(i)] += b[i];
      col_sq[static_cast<size_t>(i)] += b[i] * b[i];
    }
    float* c = cross.data();
    for (int dx = 0; dx < side; ++dx) {
      const float w = ref[(dy + r) * side + dx];
      const float* bb = b + dx;
      for (int j = 0; j < m; ++j) c[j] += w * bb[j];
    }
  }
  double s = 0, ss = 0;
  for (int i = 0; i < side; ++i)
    s += col_sum[static_cast<size_t>(i)], ss += col_sq[static_cast<size_t>(i)];
  std::vector<double> score(static_cast<size_t>(m));
  for (int j = 0; j < m; ++j) {
    if (j > 0) {
      s += col_sum[static_cast<size_t>(j + side - 1)] - col_sum[static_cast<size_t>(j - 1)];
      ss += col_sq[static_cast<size_t>(j + side - 1)] - col_sq[static_cast<size_t>(j - 1)];
    }
    const double var = ss - s * s / n;
    score[static_cast<size_t>(j)] =
        var > 1e-3 ? cross[static_cast<size_t>(j)] / std::sqrt(ref_norm2 * var) : 0.0;
  }
  for (int d = d_lo; d <= d_hi; ++d) {
    const int c = p.x - sign * d;
    if (c >= c_min && c <= c_max)
      out[static_cast<size_t>(d - d_lo)] = score[static_cast<size_t>(c - c_min)];
  }
}

struct Peak {
  int index = -1;
  double best = -2.0, runner_up = -2.0;
};

// Best entry and the best entry more than one step away from it.
Peak find_peak(const std::vector<double>& profile) {
  Peak peak;
  for (size_t i = 0; i < profile.size(); ++i) {
    if (profile[i] > peak.best) {
      peak.best = profile[i];
      peak.index = static_cast<int>(i);
    }
  }
  for (size_t i = 0; i < profile.size(); ++i) {
    if (std::abs(static_cast<int>(i) - peak.index) > 1)
      peak.runner_up = std::max(peak.runner_up, profile[i]);
  }
  return peak;
}

struct Candidate {
  cv::Point2d left, right;
};

// ncc: FAST corners of the box, each searched along its row over the disparity range.
std::vector<Candidate> ncc_candidates(const cv::Mat& L, const cv::Mat& R, const cv::Rect& box,
                                      const MatchOptions& o, int& keypoints) {
  const int r = o.patch_radius;
  const cv::Rect roi = (box + cv::Size(6, 6) - cv::Point(3, 3)) & cv::Rect(0, 0, L.cols, L.rows);
  std::vector<cv::KeyPoint> kps;
  cv::FAST(L(roi), kps, o.fast_threshold, true);
  cv::KeyPointsFilter::retainBest(
      kps, o.max_points > 0 ? std::min(o.max_points, o.max_features) : o.max_features);
  keypoints = 0;
  const int d_lo = static_cast<int>(std::ceil(o.min_disparity_px));
  const int d_hi = static_cast<int>(std::floor(o.max_disparity_px));
  std::vector<Candidate> out;
  std::vector<double> profile, back;
  for (const cv::KeyPoint& kp : kps) {
    const cv::Point p(cvRound(kp.pt.x) + roi.x, cvRound(kp.pt.y) + roi.y);
    if (!box.contains(p)) continue;
    ++keypoints;
    if (!patch_inside(L, p, r)) continue;
    zncc_profile(L, p, R, p.y, d_lo, d_hi, +1, r, profile);
    const Peak peak = find_peak(profile);
    if (peak.index < 0 || peak.best < o.min_zncc - 0.05 ||
        peak.best - peak.runner_up < o.uniqueness) {
      continue;
    }
    const int d = d_lo + peak.index;
    if (o.left_right_check) {
      const cv::Point q(p.x - d, p.y);
      zncc_profile(R, q, L, q.y, d_lo, d_hi, -1, r, back);
      const Peak back_peak = find_peak(back);
      if (back_peak.index < 0 || std::abs(d_lo + back_peak.index - d) > 1) continue;
    }
    out.push_back({cv::Point2d(p.x, p.y), cv::Point2d(p.x - d, p.y)});
  }
  return out;
}

cv::Ptr<cv::Feature2D> make_feature(Method method, int max_features) {
  switch (method) {
    case Method::orb:
      return cv::ORB::create(max_features, 1.2f, 8, 15, 0, 2, cv::ORB::HARRIS_SCORE, 15);
    case Method::akaze:
      return cv::AKAZE::create();
    case Method::sift:
      return cv::SIFT::create(max_features);
    default:
      throw std::logic_error("not a feature method");
  }
}

// Descriptor methods: keypoints of the box and of the right band, matched under the epipolar
// and disparity constraints with Lowe's ratio test.
std::vector<Candidate> descriptor_candidates(const cv::Mat& L, const cv::Mat& R,
                                             const cv::Rect& box, const MatchOptions& o,
                                             int& keypoints) {
  const cv::Rect image(0, 0, L.cols, L.rows);
  const int margin = 32;  // descriptor support around a keypoint
  const cv::Rect left_roi =
      (box + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & image;
  cv::Mat left_mask = cv::Mat::zeros(left_roi.size(), CV_8U);
  left_mask(box - left_roi.tl()).setTo(255);
  const int tol = static_cast<int>(std::ceil(o.row_tolerance_px));
  const cv::Rect band(
      box.x - static_cast<int>(std::ceil(o.max_disparity_px)), box.y - tol,
      box.width + static_cast<int>(std::ceil(o.max_disparity_px - o.min_disparity_px)),
      box.height + 2 * tol);
  const cv::Rect right_roi =
      (band + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & image;
  const cv::Rect band_in_roi = (band & image) - right_roi.tl();
  if (band_in_roi.empty()) return {};
  cv::Mat right_mask = cv::Mat::zeros(right_roi.size(), CV_8U);
  right_mask(band_in_roi).setTo(255);

  cv::Ptr<cv::Feature2D> feature = make_feature(o.method, o.max_features);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  feature->detectAndCompute(L(left_roi), left_mask, kl, dl);
  keypoints = static_cast<int>(kl.size());
  if (kl.empty()) return {};
  feature->detectAndCompute(R(right_roi), right_mask, kr, dr);
  if (kr.empty()) return {};
  const int norm = feature->defaultNorm();

  // Right keypoints by row, so each left keypoint scans only its band of rows.
  std::vector<int> order(kr.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return kr[static_cast<size_t>(a)].pt.y < kr[static_cast<size_t>(b)].pt.y;
  });
  std::vector<float> rows(order.size());
  for (size_t i = 0; i < order.size(); ++i) rows[i] = kr[static_cast<size_t>(order[i])].pt.y;

  std::vector<Candidate> out;
  for (size_t i = 0; i < kl.size(); ++i) {
    const cv::Point2d pl(kl[i].pt.x + left_roi.x, kl[i].pt.y + left_roi.y);
    const double y_in_roi = pl.y - right_roi.y;
    auto lo = std::lower_bound(rows.begin(), rows.end(),
                               static_cast<float>(y_in_roi - o.row_tolerance_px));
    auto hi = std::upper_bound(rows.begin(), rows.end(),
                               static_cast<float>(y_in_roi + o.row_tolerance_px));
    double best = 1e30, second = 1e30;
    int best_j = -1;
    for (auto it = lo; it != hi; ++it) {
      const int j = order[static_cast<size_t>(it - rows.begin())];
      const double xr = kr[static_cast<size_t>(j)].pt.x + right_roi.x;
      const double d = pl.x - xr;
      if (d < o.min_disparity_px || d > o.max_disparity_px) continue;
      const double dist = cv::norm(dl.row(static_cast<int>(i)), dr.row(j), norm);
      if (dist < best) {
        second = best;
        best = dist;
        best_j = j;
      } else if (dist < second) {
        second = dist;
      }
    }
    if (best_j < 0 || best >= o.ratio_test * second) continue;
    const cv::KeyPoint& k = kr[static_cast<size_t>(best_j)];
    out.push_back({pl, cv::Point2d(k.pt.x + right_roi.x, k.pt.y + right_roi.y)});
  }
  return out;
}

// sgbm: dense disparities of the box's band; every dense_step-th box pixel with a valid value.
std::vector<Candidate> sgbm_candidates(const cv::Mat& L, const cv::Mat& R, const cv::Rect& box,
                                       const MatchOptions& o, int& keypoints) {
  const int block = 2 * o.patch_radius + 1;
  const int min_d = static_cast<int>(std::floor(o.min_disparity_px));
  const int num_d = ((static_cast<int>(std::ceil(o.max_disparity_px)) - min_d + 1 + 15) / 16) * 16;
  const cv::Rect image(0, 0, L.cols, L.rows);
  // SGBM leaves the first min_d + num_d columns of its input without disparity: start the crop
  // that far left of the box (as far as the image allows).
  const int x0 = std::max(0, box.x - min_d - num_d - block);
  const cv::Rect crop =
      cv::Rect(x0, box.y - block, box.br().x + block - x0, box.height + 2 * block) & image;
  auto sgbm = cv::StereoSGBM::create(min_d, num_d, block, 8 * block * block, 32 * block * block, 1,
                                     0, 10, 0, 0, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity;
  sgbm->compute(L(crop), R(crop), disparity);
  keypoints = 0;
  std::vector<Candidate> out;
  const int step = std::max(1, o.dense_step);
  for (int y = box.y; y < box.br().y; y += step) {
    const short* row = disparity.ptr<short>(y - crop.y);
    for (int x = box.x; x < box.br().x; x += step) {
      ++keypoints;
      const short v = row[x - crop.x];
      if (v < min_d * 16) continue;  // invalid (SGBM marks them (min_d - 1) * 16)
      const double d = v / 16.0;
      if (d < o.min_disparity_px || d > o.max_disparity_px) continue;
      out.push_back({cv::Point2d(x, y), cv::Point2d(x - d, y)});
    }
  }
  return out;
}

// Row model yR - yL = a + b * (xL - x_centre), fitted by RANSAC; returns the inlier flags.
std::vector<bool> ransac_rows(const std::vector<Candidate>& c, double x_centre,
                              const MatchOptions& o, double& a, double& b) {
  const size_t n = c.size();
  std::vector<bool> inlier(n, false);
  a = b = 0.0;
  if (n == 0) return inlier;
  auto residual = [&](size_t i, double aa, double bb) {
    return (c[i].right.y - c[i].left.y) - (aa + bb * (c[i].left.x - x_centre));
  };
  size_t best_count = 0;
  double best_a = 0, best_b = 0;
  std::mt19937 rng(12345);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  const int iterations = n < 2 ? 1 : o.ransac_iterations;
  for (int it = 0; it < iterations; ++it) {
    double aa, bb;
    if (n < 2) {
      aa = c[0].right.y - c[0].left.y;
      bb = 0;
    } else {
      const size_t i = pick(rng), j = pick(rng);
      const double dx = c[j].left.x - c[i].left.x;
      if (i == j || std::abs(dx) < 1.0) {  // one point: a constant offset
        aa = c[i].right.y - c[i].left.y;
        bb = 0;
      } else {
        bb = ((c[j].right.y - c[j].left.y) - (c[i].right.y - c[i].left.y)) / dx;
        aa = (c[i].right.y - c[i].left.y) - bb * (c[i].left.x - x_centre);
      }
    }
    size_t count = 0;
    for (size_t k = 0; k < n; ++k) count += std::abs(residual(k, aa, bb)) <= o.ransac_threshold_px;
    if (count > best_count) {
      best_count = count;
      best_a = aa;
      best_b = bb;
    }
  }
  // Least-squares refit on the inliers (slope only when they span some width).
  double s1 = 0, sx = 0, sxx = 0, sy = 0, sxy = 0;
  for (size_t k = 0; k < n; ++k) {
    if (std::abs(residual(k, best_a, best_b)) > o.ransac_threshold_px) continue;
    const double x = c[k].left.x - x_centre, y = c[k].right.y - c[k].left.y;
    s1 += 1;
    sx += x;
    sxx += x * x;
    sy += y;
    sxy += x * y;
  }
  const double det = s1 * sxx - sx * sx;
  if (s1 >= 3 && det > 1e-6 * s1 * s1 * 100) {
    b = (s1 * sxy - sx * sy) / det;
    a = (sy - b * sx) / s1;
  } else {
    a = s1 > 0 ? sy / s1 : best_a;
    b = 0;
  }
  for (size_t k = 0; k < n; ++k) inlier[k] = std::abs(residual(k, a, b)) <= o.ransac_threshold_px;
  return inlier;
}

}  // namespace

bool refine_disparity(const cv::Mat& L, const cv::Mat& R, const cv::Point& p, double row_offset_px,
                      const MatchOptions& o, double& disparity_px, double& zncc) {
  const int r = o.patch_radius;
  if (!patch_inside(L, p, r)) return false;
  const int row = p.y + static_cast<int>(std::lround(row_offset_px));
  const int d0 = static_cast<int>(std::lround(disparity_px));
  // Integer ZNCC over d0 +- 3; the peak must be inside +-2 to fit a parabola.
  double c[7];
  for (int k = -3; k <= 3; ++k) {
    const cv::Point q(p.x - d0 - k, row);
    c[k + 3] = patch_inside(R, q, r) ? zncc_at(L, p, R, q, r) : -2.0;
  }
  const int best = static_cast<int>(std::max_element(c + 1, c + 6) - c);
  if (c[best] < o.min_zncc - 0.1 || c[best - 1] < -1.5 || c[best + 1] < -1.5) return false;
  const double denom = c[best - 1] - 2 * c[best] + c[best + 1];
  const double offset = denom < 0 ? 0.5 * (c[best - 1] - c[best + 1]) / denom : 0.0;
  double d = d0 + (best - 3) + std::clamp(offset, -0.5, 0.5);
  const double d_parabola = d;

  // Gauss-Newton on d, gain g and offset h: min sum (g R(x - d, y') + h - L(x, y))^2, with
  // y' = y + row_offset. The whole patch shifts by one sub-pixel amount, so each iteration
  // interpolates one (2r+1) x (2r+3) window once (Catmull-Rom along the row: bilinear would
  // pull disparities towards whole pixels by a few hundredths; linear across rows, whose offset
  // is only the small rectification residual) and takes the horizontal gradient as the central
  // difference of that window.
  const int side = 2 * r + 1, wide = side + 2;
  const int n = side * side;
  std::vector<double> lv(static_cast<size_t>(n)), window(static_cast<size_t>(side * wide));
  for (int dy = -r, k = 0; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx, ++k)
      lv[static_cast<size_t>(k)] = L.at<uchar>(p.y + dy, p.x + dx);
  const double yr = p.y + row_offset_px;
  const int y0 = static_cast<int>(std::floor(yr)) - r;
  const double fy = yr - std::floor(yr);
  if (y0 < 0 || y0 + side >= R.rows) return false;
  // Fills `window` for the shift d; false when it leaves the image.
  auto interpolate = [&](double dd) {
    const double xr = p.x - dd;
    const int x0 = static_cast<int>(std::floor(xr)) - r - 1;
    const double t = xr - std::floor(xr);
    if (x0 - 1 < 0 || x0 + wide + 2 >= R.cols) return false;
    const double t2 = t * t, t3 = t2 * t;
    const double wm = 0.5 * (-t3 + 2 * t2 - t), w0 = 0.5 * (3 * t3 - 5 * t2 + 2),
                 w1 = 0.5 * (-3 * t3 + 4 * t2 + t), w2 = 0.5 * (t3 - t2);
    for (int j = 0; j < side; ++j) {
      const uchar* a = R.ptr<uchar>(y0 + j) + x0;
      const uchar* b = R.ptr<uchar>(y0 + j + 1) + x0;
      double* w = &window[static_cast<size_t>(j * wide)];
      for (int i = 0; i < wide; ++i) {
        const double va = wm * a[i - 1] + w0 * a[i] + w1 * a[i + 1] + w2 * a[i + 2];
        const double vb = fy > 0 ? wm * b[i - 1] + w0 * b[i] + w1 * b[i + 1] + w2 * b[i + 2] : 0.0;
        w[i] = (1 - fy) * va + fy * vb;
      }
    }
    return true;
  };
  double g = 1.0, h = 0.0;
  for (int iteration = 0; iteration < 8; ++iteration) {
    if (!interpolate(d)) return false;
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0;
    for (int j = 0, k = 0; j < side; ++j) {
      const double* w = &window[static_cast<size_t>(j * wide)];
      for (int i = 1; i <= side; ++i, ++k) {
        const double v = w[i];
        // Residual e = g v + h - l; de/dd = -g * dR/dx (the sample point moves by -d).
        const double jd = -g * 0.5 * (w[i + 1] - w[i - 1]);
        const double e = g * v + h - lv[static_cast<size_t>(k)];
        a00 += jd * jd;
        a01 += jd * v;
        a02 += jd;
        a11 += v * v;
        a12 += v;
        a22 += 1.0;
        b0 -= jd * e;
        b1 -= v * e;
        b2 -= e;
      }
    }
    Eigen::Matrix3d A;
    A << a00, a01, a02, a01, a11, a12, a02, a12, a22;
    const Eigen::Vector3d step = A.ldlt().solve(Eigen::Vector3d(b0, b1, b2));
    if (!step.allFinite()) return false;
    d += step(0);
    g += step(1);
    h += step(2);
    if (std::abs(d - d_parabola) > 1.0 || g <= 0.2 || g > 5.0) return false;
    if (std::abs(step(0)) < 2e-3) break;
  }
  // Correlation of the final alignment.
  if (!interpolate(d)) return false;
  double sl = 0, sr = 0, sll = 0, srr = 0, slr = 0;
  for (int j = 0, k = 0; j < side; ++j) {
    const double* w = &window[static_cast<size_t>(j * wide)];
    for (int i = 1; i <= side; ++i, ++k) {
      const double a = lv[static_cast<size_t>(k)], b = w[i];
      sl += a;
      sr += b;
      sll += a * a;
      srr += b * b;
      slr += a * b;
    }
  }
  const double var = (sll - sl * sl / n) * (srr - sr * sr / n);
  zncc = var > 1e-9 ? (slr - sl * sr / n) / std::sqrt(var) : 0.0;
  if (zncc < o.min_zncc) return false;
  disparity_px = d;
  return true;
}

MatchResult match_box(const cv::Mat& left, const cv::Mat& right, const cv::Rect& box,
                      const MatchOptions& o) {
  const cv::Mat L = to_grey(left, "left");
  const cv::Mat R = to_grey(right, "right");
  if (L.size() != R.size()) {
    throw std::invalid_argument("match: left and right images differ in size");
  }
  if (!(o.max_disparity_px >= o.min_disparity_px) || !std::isfinite(o.max_disparity_px) ||
      !std::isfinite(o.min_disparity_px)) {
    throw std::invalid_argument("match: disparity range must have finite max >= min");
  }
  if (o.patch_radius < 1 || o.patch_radius > 15) {
    throw std::invalid_argument("match: patch_radius must be in [1, 15]");
  }
  MatchResult result;
  result.box = box & cv::Rect(0, 0, L.cols, L.rows);
  if (result.box.empty()) {
    result.box = {};
    return result;
  }
  std::vector<Candidate> candidates;
  switch (o.method) {
    case Method::ncc:
      candidates = ncc_candidates(L, R, result.box, o, result.keypoints_left);
      break;
    case Method::sgbm:
      candidates = sgbm_candidates(L, R, result.box, o, result.keypoints_left);
      break;
    default:
      candidates = descriptor_candidates(L, R, result.box, o, result.keypoints_left);
      break;
  }
  result.candidates = static_cast<int>(candidates.size());
  const double x_centre = result.box.x + 0.5 * result.box.width;
  const std::vector<bool> inlier =
      ransac_rows(candidates, x_centre, o, result.row_offset_px, result.row_slope);
  std::set<std::pair<int, int>> seen;  // one match per left pixel
  for (size_t i = 0; i < candidates.size(); ++i) {
    if (!inlier[i]) continue;
    ++result.ransac_inliers;
    const Candidate& c = candidates[i];
    const double row_offset = result.row_offset_px + result.row_slope * (c.left.x - x_centre);
    Correspondence m;
    if (!o.subpixel) {
      m.left = {c.left.x, c.left.y};
      m.right = {c.right.x, c.right.y};
      m.disparity_px = c.left.x - c.right.x;
      m.score = 1.0;
      result.matches.push_back(m);
      continue;
    }
    const cv::Point p(cvRound(c.left.x), cvRound(c.left.y));
    if (!seen.insert({p.x, p.y}).second) continue;
    double d = c.left.x - c.right.x + (p.x - c.left.x);  // disparity at the snapped pixel
    double score = 0;
    if (!refine_disparity(L, R, p, row_offset, o, d, score)) continue;
    if (d < o.min_disparity_px - 1.0 || d > o.max_disparity_px + 1.0) continue;
    m.left = {p.x, p.y};
    m.right = {p.x - d, p.y + row_offset};
    m.disparity_px = d;
    m.score = score;
    result.matches.push_back(m);
  }
  return result;
}

}  // namespace thermovis::match
