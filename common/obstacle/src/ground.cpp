#include "thermovis/obstacle/ground.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::obstacle {

namespace {

constexpr util::EnumName<GroundStatus> kStatusNames[] = {
    {GroundStatus::ok, "ok"},
    {GroundStatus::no_disparity, "no_disparity"},
    {GroundStatus::no_ground, "no_ground"}};

// One pixel with a point, as the fit reads it: its row, 1 / rho and the features of
// 1 / rho = w . (tan alpha, sin beta, cos beta).
struct GroundSample {
  int row;
  float inv_rho;
  Eigen::Vector3f features;
};

// A candidate ground's row disparity at a row: f A k sin(beta + phi).
double row_disparity(double f_baseline, double k, double phi, double beta) {
  return f_baseline * k * std::sin(beta + phi);
}

}  // namespace

std::string status_name(GroundStatus status) {
  return util::name_of(kStatusNames, status, "unknown");
}

GroundPlane prior_plane(const GroundPrior& prior) {
  if (!std::isfinite(prior.camera_height_m) || !(prior.camera_height_m > 0)) {
    throw std::invalid_argument("ground prior: camera height " +
                                std::to_string(prior.camera_height_m) + " m is not > 0");
  }
  if (!std::isfinite(prior.pitch_rad) || !std::isfinite(prior.roll_rad)) {
    throw std::invalid_argument("ground prior: pitch or roll is not finite");
  }
  GroundPlane p;
  const double cp = std::cos(prior.pitch_rad);
  p.normal = Eigen::Vector3d(std::sin(prior.roll_rad) * cp, std::cos(prior.roll_rad) * cp,
                             std::sin(prior.pitch_rad));
  p.height_m = prior.camera_height_m;
  return p;
}

GroundPlane plane_in_frame(const GroundPlane& plane_a, const Eigen::Isometry3d& T_a_b) {
  // n . (R p_b + t) = h  <=>  (R^T n) . p_b = h - n . t
  GroundPlane b;
  b.normal = T_a_b.linear().transpose() * plane_a.normal;
  b.height_m = plane_a.height_m - plane_a.normal.dot(T_a_b.translation());
  return b;
}

double pitch_of(const GroundPlane& rig_plane) {
  return std::asin(std::clamp(rig_plane.normal.z(), -1.0, 1.0));
}
double roll_of(const GroundPlane& rig_plane) {
  return std::atan2(rig_plane.normal.x(), rig_plane.normal.y());
}

bool within_search(const GroundPlane& plane, const GroundPlane& prior,
                   const GroundOptions& options) {
  const double pitch_change = std::abs(std::atan2(plane.normal.z(), plane.normal.y()) -
                                       std::atan2(prior.normal.z(), prior.normal.y()));
  const double height_ratio = plane.height_m / prior.height_m;
  return pitch_change <= options.max_pitch_change_rad * 1.5 &&
         height_ratio <= options.max_height_factor * 1.1 &&
         height_ratio >= 1.0 / (options.max_height_factor * 1.1) &&
         std::abs(plane.normal.x() - prior.normal.x()) <= 0.1;
}

GroundTracker::GroundTracker(const GroundTrackerOptions& options) : options_(options) {
  if (!(options.max_pitch_change_rad > 0) || !(options.max_height_factor > 1)) {
    throw std::invalid_argument(
        "ground tracker: the pitch change must be > 0 and the height factor > 1");
  }
}

GroundOptions GroundTracker::search_options(const GroundOptions& prior_options) const {
  GroundOptions o = prior_options;
  if (!last_) return o;
  o.max_pitch_change_rad = std::min(o.max_pitch_change_rad, options_.max_pitch_change_rad);
  o.max_height_factor = std::min(o.max_height_factor, options_.max_height_factor);
  return o;
}

void GroundTracker::update(const GroundFit& fit) {
  if (fit.ok()) {
    last_ = fit.plane;
  } else {
    last_.reset();
  }
}

GroundFit fit_ground(const cv::Mat& points, const std::vector<double>& row_beta,
                     double f_baseline_px_m, const GroundPlane& prior,
                     const GroundOptions& options) {
  if (points.type() != CV_32FC3) {
    throw std::invalid_argument("fit_ground: the points image is not CV_32FC3");
  }
  if (static_cast<int>(row_beta.size()) != points.rows) {
    throw std::invalid_argument("fit_ground: " + std::to_string(row_beta.size()) +
                                " row angles for " + std::to_string(points.rows) + " rows");
  }
  if (!(f_baseline_px_m > 0) || !(prior.height_m > 0)) {
    throw std::invalid_argument("fit_ground: f * baseline and the prior's height must be > 0");
  }
  GroundFit fit;
  fit.plane = prior;
  const Eigen::Vector3d w0 = prior.normal / prior.height_m;

  std::vector<GroundSample> samples;
  samples.reserve(points.total() / 2);
  const int column_step = std::max(1, options.column_step);
  for (int r = 0; r < points.rows; ++r) {
    const auto* row = points.ptr<cv::Vec3f>(r);
    for (int c = 0; c < points.cols; c += column_step) {
      const cv::Vec3f& p = row[c];
      if (!std::isfinite(p[2])) continue;
      const float rho = std::sqrt(p[1] * p[1] + p[2] * p[2]);
      if (!(rho > 0)) continue;
      samples.push_back({r, 1.0f / rho, Eigen::Vector3f(p[0] / rho, p[1] / rho, p[2] / rho)});
    }
  }
  fit.valid_pixels = static_cast<int>(samples.size());
  const double total = static_cast<double>(points.total()) / column_step;
  if (samples.empty() || fit.valid_pixels < options.min_valid_share * total) {
    fit.status = GroundStatus::no_disparity;
    std::ostringstream why;
    why << "disparities on " << fit.valid_pixels << " of " << static_cast<int>(total)
        << " pixels (fewer than " << options.min_valid_share * 100 << " %)";
    fit.message = why.str();
    return fit;
  }

  // The v-disparity: per row, a histogram of the row disparity with the prior's w_x taken out.
  double v_max = 0;
  for (const GroundSample& s : samples) {
    v_max = std::max(v_max, f_baseline_px_m * (s.inv_rho - w0.x() * s.features.x()));
  }
  const int bins = std::max(1, static_cast<int>(std::ceil(v_max / options.bin_px)) + 2);
  cv::Mat histogram = cv::Mat::zeros(points.rows, bins, CV_32S);
  std::vector<int> row_valid(static_cast<std::size_t>(points.rows), 0);
  for (const GroundSample& s : samples) {
    const double v = f_baseline_px_m * (s.inv_rho - w0.x() * s.features.x());
    if (v < 0) continue;
    ++histogram.at<int>(s.row, static_cast<int>(v / options.bin_px));
    ++row_valid[static_cast<std::size_t>(s.row)];
  }
  // Cumulative per row, so a candidate's votes in a window are two reads.
  cv::Mat cumulative(points.rows, bins + 1, CV_32S);
  for (int r = 0; r < points.rows; ++r) {
    int sum = 0;
    cumulative.at<int>(r, 0) = 0;
    for (int b = 0; b < bins; ++b) cumulative.at<int>(r, b + 1) = sum += histogram.at<int>(r, b);
  }
  auto votes = [&](int r, double v) {
    const double tol = options.tolerance_px + options.tolerance_share * v;
    const int lo = std::clamp(static_cast<int>(std::floor((v - tol) / options.bin_px)), 0, bins);
    const int hi = std::clamp(static_cast<int>(std::ceil((v + tol) / options.bin_px)), 0, bins);
    return cumulative.at<int>(r, hi) - cumulative.at<int>(r, lo);
  };

  // The search about the prior: phi (pitch) and k = 1 / height of the plane's yz part. A row's
  // votes are capped (a wall across the view fills one row of the v-disparity; the ground is
  // spread over many), so the score counts rows that hold the ground.
  const double k0 = std::hypot(w0.y(), w0.z());
  const double phi0 = std::atan2(w0.z(), w0.y());
  const int row_cap = std::max(options.min_row_pixels, points.cols / column_step / 4);
  const double log_factor = std::log(options.max_height_factor);
  double best_score = -1, best_k = k0, best_phi = phi0, best_offset = 0;
  std::vector<double> unit_v(static_cast<std::size_t>(points.rows));  // the row disparity / k
  // Candidates phi0 + i * phi_step (|i| <= phi_count) about phi_centre, and log(k / k_centre) =
  // j * log_step (|j| <= k_count), on every row_stride-th row.
  auto search = [&](double phi_centre, double phi_step, int phi_count, double k_centre,
                    double log_step, int k_count, int row_stride) {
    for (int ip = -phi_count; ip <= phi_count; ++ip) {
      const double phi = phi_centre + ip * phi_step;
      if (std::abs(phi - phi0) > options.max_pitch_change_rad + 1e-12) continue;
      for (int r = 0; r < points.rows; r += row_stride) {
        unit_v[static_cast<std::size_t>(r)] =
            row_disparity(f_baseline_px_m, 1.0, phi, row_beta[static_cast<std::size_t>(r)]);
      }
      for (int ih = -k_count; ih <= k_count; ++ih) {
        const double k = k_centre * std::exp(ih * log_step);
        if (std::abs(std::log(k / k0)) > log_factor + 1e-12) continue;
        double score = 0;
        for (int r = 0; r < points.rows; r += row_stride) {
          const double v = k * unit_v[static_cast<std::size_t>(r)];
          if (v < options.min_ground_v_px) continue;
          score += std::min(votes(r, v), row_cap);
        }
        // Ties (an empty search) keep the candidate nearest the prior.
        const double offset = std::abs(phi - phi0) / options.max_pitch_change_rad +
                              std::abs(std::log(k / k0)) / log_factor;
        if (score > best_score || (score == best_score && offset < best_offset)) {
          best_score = score;
          best_k = k;
          best_phi = phi;
          best_offset = offset;
        }
      }
    }
  };
  // Coarse over the whole search on every other row, then fine about the best.
  const double coarse_phi = 4 * options.pitch_step_rad;
  const int phi_count = static_cast<int>(std::ceil(options.max_pitch_change_rad / coarse_phi));
  const int height_steps = std::max(2, options.height_steps);
  const double coarse_k = 4 * 2 * log_factor / height_steps;
  const int k_count = static_cast<int>(std::ceil(log_factor / coarse_k));
  search(phi0, coarse_phi, phi_count, k0, coarse_k, k_count, 2);
  best_score = -1;
  search(best_phi, options.pitch_step_rad, 4, best_k, coarse_k / 4, 4, 1);

  // Least squares on the pixels near the best candidate, then again on those near the refined
  // plane, up to max_refits times or until it stays (the candidate is a point of the search's
  // grid, and its pixels include the feet of walls and targets that refits leave out).
  Eigen::Vector3d w(w0.x(), best_k * std::cos(best_phi), best_k * std::sin(best_phi));
  std::vector<int> row_inliers(static_cast<std::size_t>(points.rows), 0);
  for (int pass = 0; pass < std::max(1, options.max_refits); ++pass) {
    // The normal equations' sums, one scalar each (Eigen's 3 x 3 temporaries per pixel cost
    // more than the rest of the fit).
    double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0, bx = 0, by = 0, bz = 0;
    std::fill(row_inliers.begin(), row_inliers.end(), 0);
    int inliers = 0;
    for (const GroundSample& s : samples) {
      const double x = s.features.x(), y = s.features.y(), z = s.features.z();
      const double v_ground = f_baseline_px_m * (w.x() * x + w.y() * y + w.z() * z);
      if (v_ground < options.min_ground_v_px) continue;
      const double tol = options.tolerance_px + options.tolerance_share * v_ground;
      if (std::abs(f_baseline_px_m * s.inv_rho - v_ground) >= tol) continue;
      xx += x * x;
      xy += x * y;
      xz += x * z;
      yy += y * y;
      yz += y * z;
      zz += z * z;
      bx += x * s.inv_rho;
      by += y * s.inv_rho;
      bz += z * s.inv_rho;
      ++inliers;
      ++row_inliers[static_cast<std::size_t>(s.row)];
    }
    Eigen::Matrix3d A;
    A << xx, xy, xz, xy, yy, yz, xz, yz, zz;
    const Eigen::Vector3d b(bx, by, bz);
    fit.inlier_pixels = inliers;
    if (inliers < 10) break;
    const Eigen::Vector3d refined = A.ldlt().solve(b);
    if (!refined.allFinite() || !(refined.norm() > 0)) break;
    const bool settled = (refined - w).norm() < 1e-4 * w.norm();
    w = refined;
    if (settled) break;
  }

  fit.rows_searched = 0;
  fit.rows_with_ground = 0;
  int valid_in_searched = 0;
  for (int r = 0; r < points.rows; ++r) {
    if (row_disparity(f_baseline_px_m, best_k, best_phi, row_beta[r]) < options.min_ground_v_px)
      continue;
    ++fit.rows_searched;
    valid_in_searched += row_valid[static_cast<std::size_t>(r)];
    fit.rows_with_ground += row_inliers[static_cast<std::size_t>(r)] >= options.min_row_pixels;
  }
  GroundPlane found;
  found.height_m = 1.0 / w.norm();
  found.normal = w * found.height_m;
  const double pitch_change = std::abs(std::atan2(found.normal.z(), found.normal.y()) - phi0);
  std::ostringstream why;
  if (fit.rows_searched == 0 || fit.rows_with_ground < options.min_row_share * fit.rows_searched ||
      fit.inlier_pixels < options.min_inlier_share * std::max(1, valid_in_searched)) {
    why << "ground near the prior on " << fit.rows_with_ground << " of " << fit.rows_searched
        << " rows and " << fit.inlier_pixels << " of " << valid_in_searched << " pixels";
    fit.status = GroundStatus::no_ground;
  } else if (!within_search(found, prior, options)) {
    why << "the plane fitted (height " << found.height_m << " m, pitch change " << pitch_change
        << " rad) is beyond the prior's search";
    fit.status = GroundStatus::no_ground;
  } else {
    fit.status = GroundStatus::ok;
    fit.plane = found;
    return fit;
  }
  fit.message = why.str();
  return fit;
}

}  // namespace thermovis::obstacle
