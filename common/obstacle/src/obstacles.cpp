#include "thermovis/obstacle/obstacles.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/match/region_align.hpp"
#include "thermovis/obstacle/robust.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::obstacle {

namespace {

constexpr util::EnumName<PairBand> kBandNames[] = {{PairBand::visible, "visible"},
                                                   {PairBand::infrared, "infrared"}};
constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr int kRightSteps = 16;  // the matchers' sub-pixel steps per px

// Horizontal part of a point (along the ground whose downward normal is n), m.
double horizontal_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  return (p - n.dot(p) * n).norm();
}

// An obstacle's nearest stixel, of stixels[begin, end) (not empty).
const Stixel& nearest_stixel(const std::vector<Stixel>& stixels, std::size_t begin,
                             std::size_t end) {
  const Stixel* nearest = &stixels[begin];
  for (std::size_t i = begin; i < end; ++i) {
    if (stixels[i].distance_m < nearest->distance_m) nearest = &stixels[i];
  }
  return *nearest;
}

// How far apart two stixels of one obstacle may range, the nearer at distance_m.
double same_obstacle_within_m(const ObstacleOptions& options, double distance_m) {
  return options.cluster_tolerance_m + options.cluster_tolerance_share * distance_m;
}

// An obstacle's near face: its stixels no farther than this, within 2 sigma of the nearest one
// (the nearest alone is biased near by its noise: the least of several noisy distances).
double near_face_limit_m(const Stixel& nearest) { return nearest.distance_m + 2 * nearest.sigma_m; }

// Buffers of one pair's analysis kept from capture to capture, so that none is allocated per
// capture once sized: per thread (the detector's methods are const and may run on several
// threads at once) and per band (the pairs' reduced grids differ in size).
struct PairScratch {
  cv::Mat points;                               // CV_32FC3, ObstacleDetector::triangulate
  cv::Mat stand;                                // CV_8U, ObstacleDetector::stixels
  std::vector<std::pair<int, double>> members;  // a stixel's rows and disparities
  std::vector<double> ds;                       // their disparities
  std::vector<double> slopes;                   // of pairs of them (px per row)
};

PairScratch& scratch_for(PairBand band) {
  thread_local std::array<PairScratch, 2> scratch;
  return scratch[band == PairBand::visible ? 0 : 1];
}

// The point of the left pixel (column, row) of a reduced grid at disparity d (reduced px), in
// the pair's left rectified frame; false where it does not triangulate.
bool point_at(const range::RangingGeometry& g, double column, double row, double d,
              Eigen::Vector3d& p) {
  const range::PointTriangulation t = range::triangulate(g, Eigen::Vector2d(column, row), d);
  if (!t.valid) return false;
  p = t.position_left_rect;
  return true;
}

}  // namespace

double median_of(std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::pair<double, double> median_and_deviation(std::vector<double>& v) {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  if (v.empty()) return {nan, nan};
  // One sort instead of two selections: the deviations of the values below the median and of
  // those above are each in order in the sorted values, so the median of all of them is n / 2
  // steps of merging the two. (d - m and m - d are exactly |d - m|: the same values.)
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size(), m = n / 2;
  const double median = v[m];
  std::size_t below = m, above = m;  // the next deviations: of v[below - 1] and of v[above]
  double deviation = 0;
  for (std::size_t k = 0; k <= m; ++k) {
    if (below == 0 || (above < n && v[above] - median <= median - v[below - 1])) {
      deviation = v[above++] - median;
    } else {
      deviation = median - v[--below];
    }
  }
  return {median, deviation};
}

std::string band_name(PairBand band) { return util::name_of(kBandNames, band, "unknown"); }

bool ObstacleResult::ok() const {
  return std::any_of(pairs.begin(), pairs.end(), [](const PairObstacles& p) { return p.ok(); });
}

ObstacleDetector::ObstacleDetector(const camera::RectifiedIntrinsics& grid,
                                   std::vector<PairSetup> pairs,
                                   const Eigen::Isometry3d& T_ref_reporting,
                                   const GroundPrior& prior, const ObstacleOptions& options)
    : grid_(grid), T_ref_reporting_(T_ref_reporting), options_(options) {
  if (grid.width <= 0 || grid.height <= 0 || !(grid.f > 0)) {
    throw std::invalid_argument("obstacles: the grid is empty or its f is not > 0");
  }
  const int k = options.reduction;
  if (k < 1 || grid.width < 16 * k || grid.height < 16 * k) {
    throw std::invalid_argument("obstacles: reduction " + std::to_string(k) +
                                " is < 1 or leaves a grid under 16 px");
  }
  if (!(options.min_distance_m > 0) || !(options.max_distance_m > options.min_distance_m)) {
    throw std::invalid_argument("obstacles: distances must be 0 < min < max");
  }
  const GroundPlane rig_ground = prior_plane(prior);
  for (const PairSetup& setup : pairs) {
    for (const Pair& other : pairs_) {
      if (other.setup.band == setup.band) {
        throw std::invalid_argument("obstacles: the " + band_name(setup.band) +
                                    " pair is given twice");
      }
    }
    if (!(setup.geometry.baseline_m > 0)) {
      throw std::invalid_argument("obstacles: the " + band_name(setup.band) +
                                  " pair's baseline is not > 0");
    }
    const int s = setup.image_reduction;
    if (s < 1 || k % s != 0) {
      throw std::invalid_argument("obstacles: the " + band_name(setup.band) +
                                  " pair's image reduction " + std::to_string(s) +
                                  " does not divide the reduction " + std::to_string(k));
    }
    Pair p(setup);
    p.reduction = k;
    p.prior = plane_in_frame(rig_ground, setup.geometry.T_ref_left_rect);
    p.T_reporting_rect = T_ref_reporting.inverse() * setup.geometry.T_ref_left_rect;
    // The prior's horizon (its ground's row disparity is 0 there), the rows kept above it, and
    // below, the ground up to min_distance_m ahead (nearer is outside the disparity range) and
    // the rows a stixel's base may reach below its foot.
    const double beta_horizon = std::atan2(-p.prior.normal.z(), p.prior.normal.y());
    const double top = grid.cy + grid.f * (beta_horizon - options.above_horizon_rad);
    const double bottom =
        grid.cy + grid.f * (beta_horizon + std::atan2(p.prior.height_m, options.min_distance_m)) +
        (options.foot_rows + 2) * k;
    int last_row = std::clamp(static_cast<int>(std::ceil(bottom)), 16 * k, grid.height);
    // Whole pixels of a reduced image: the rows kept start and end on its rows.
    last_row -= last_row % s;
    const int first_row = std::clamp(static_cast<int>(std::floor(top)), 0, last_row - 16 * k);
    const int kept = (last_row - first_row) / k;
    p.first_row = last_row - kept * k;
    camera::RectifiedIntrinsics r = grid;
    r.width = grid.width / k;
    r.height = kept;
    r.f = grid.f / k;
    r.cx = (grid.cx + 0.5) / k - 0.5;
    r.cy = (grid.cy - p.first_row + 0.5) / k - 0.5;
    p.reduced = setup.geometry;
    p.reduced.grid = camera::RectifiedCamera(r);
    p.row_beta.resize(static_cast<std::size_t>(r.height));
    for (int row = 0; row < r.height; ++row) {
      p.row_beta[static_cast<std::size_t>(row)] = (row - r.cy) / r.f;
    }
    max_disparity_px_ =
        std::max(max_disparity_px_, range::max_disparity_for(p.reduced, options.min_distance_m));
    pairs_.push_back(std::move(p));
  }
  for (Pair& p : pairs_) {
    angle_tables(p, max_disparity_px_);
    if (!p.reduced.right_centre_m.isZero()) right_rows(p);
  }
  // The visible pair on the grid itself, for the far band: its columns' tables (its rows are
  // the fitted ground's, each capture).
  for (const Pair& p : pairs_) {
    if (!options.far_band || k == 1 || p.setup.band != PairBand::visible ||
        p.setup.image_reduction != 1 || !p.reduced.right_centre_m.isZero()) {
      continue;
    }
    Pair band(p.setup);
    band.prior = p.prior;
    band.T_reporting_rect = p.T_reporting_rect;
    angle_tables(band, range::max_disparity_for(band.reduced, options.far_band_min_distance_m));
    far_band_ = std::move(band);
  }
}

void ObstacleDetector::angle_tables(Pair& p, double max_disparity_px) {
  // For triangulate: its left columns, and its right eye's column c - d at the matchers' 1/16
  // px steps over the disparity range (other disparities computed).
  const camera::RectifiedCamera& g = p.reduced.grid;
  const int width = g.intrinsics().width;
  p.sin_left.resize(static_cast<std::size_t>(width));
  p.cos_left.resize(p.sin_left.size());
  for (int c = 0; c < width; ++c) {
    const double alpha = g.alpha_of_column(c);
    p.sin_left[static_cast<std::size_t>(c)] = std::sin(alpha);
    p.cos_left[static_cast<std::size_t>(c)] = std::cos(alpha);
  }
  p.first_right_step = -kRightSteps * static_cast<int>(std::ceil(max_disparity_px + 16));
  p.sin_right.resize(static_cast<std::size_t>(kRightSteps * width - p.first_right_step));
  p.cos_right.resize(p.sin_right.size());
  for (std::size_t i = 0; i < p.sin_right.size(); ++i) {
    const double a = g.alpha_of_column(
        static_cast<double>(static_cast<int>(i) + p.first_right_step) / kRightSteps);
    p.sin_right[i] = std::abs(a) < M_PI / 2 ? std::sin(a) : kNan;
    p.cos_right[i] = std::cos(a);
  }
}

void ObstacleDetector::right_rows(Pair& p) const {
  // The row offset of a right eye off the grid's axis falls as 1 / distance: on the paper rig's
  // infrared pair (its baseline 11 deg from the visible one, mostly forward) 1-3 grid px on the
  // road a few metres ahead, where its edges run across the rows, so block matching along the
  // rows read them with a disparity off by several px and the road stood above its ground. Each
  // left ray's point on the prior ground (the road, or an object standing on it at about the
  // distance of the ground behind its lower part; above the horizon, infinity) gives the right
  // eye's row.
  const camera::RectifiedCamera& g = p.reduced.grid;
  const auto& r = g.intrinsics();
  const Eigen::Vector3d& centre = p.reduced.right_centre_m;
  p.right_map_x.create(r.height, r.width, CV_32FC1);
  p.right_map_y.create(r.height, r.width, CV_32FC1);
  p.right_row_per_disparity.create(r.height, r.width, CV_32FC1);
  for (int row = 0; row < r.height; ++row) {
    const double beta = p.row_beta[static_cast<std::size_t>(row)];
    auto* mx = p.right_map_x.ptr<float>(row);
    auto* my = p.right_map_y.ptr<float>(row);
    auto* k = p.right_row_per_disparity.ptr<float>(row);
    for (int c = 0; c < r.width; ++c) {
      const auto i = static_cast<std::size_t>(c);
      const Eigen::Vector3d u(p.sin_left[i], p.cos_left[i] * std::sin(beta),
                              p.cos_left[i] * std::cos(beta));
      // The ray's point on the ground, scaled by 1 / its distance (at infinity above the
      // horizon: the same row in both eyes).
      const double inverse_along = std::max(0.0, p.prior.normal.dot(u)) / p.prior.height_m;
      const Eigen::Vector3d seen = u - inverse_along * centre;
      const double beta_right = std::atan2(seen.y(), seen.z());
      mx[c] = static_cast<float>(c);
      my[c] = static_cast<float>(row + (beta_right - beta) * r.f);
      // To first order the right eye's row offset is f (C_z sin beta - C_y cos beta) / (rho
      // cos alpha) at the distance rho along the ray, and the disparity f A cos alpha / rho.
      const double cos_a = p.cos_left[i];
      k[c] = static_cast<float>((centre.z() * std::sin(beta) - centre.y() * std::cos(beta)) /
                                (p.reduced.baseline_m * cos_a * cos_a));
    }
  }
}

const ObstacleDetector::Pair& ObstacleDetector::pair(PairBand band) const {
  for (const Pair& p : pairs_) {
    if (p.setup.band == band) return p;
  }
  throw std::invalid_argument("obstacles: no " + band_name(band) + " pair set up");
}

bool ObstacleDetector::has(PairBand band) const {
  return std::any_of(pairs_.begin(), pairs_.end(),
                     [band](const Pair& p) { return p.setup.band == band; });
}

const camera::RectifiedIntrinsics& ObstacleDetector::reduced_grid(PairBand band) const {
  return pair(band).reduced.grid.intrinsics();
}

int ObstacleDetector::first_grid_row(PairBand band) const { return pair(band).first_row; }

void ObstacleDetector::reduce_pair(PairBand band, const cv::Mat& left, const cv::Mat& right,
                                   cv::Mat& left8, cv::Mat& right8) const {
  const Pair& p = pair(band);
  const int s = p.setup.image_reduction, k = options_.reduction / s;
  const cv::Size image(grid_.width / s, grid_.height / s);
  if (left.size() != image || right.size() != left.size()) {
    throw std::invalid_argument("obstacles: the " + band_name(band) + " images are not " +
                                std::to_string(image.width) + "x" + std::to_string(image.height) +
                                (s == 1 ? " (the grid)" : " (the grid reduced by its reduction)"));
  }
  const auto& r = p.reduced.grid.intrinsics();
  const cv::Rect crop(0, p.first_row / s, r.width * k, r.height * k);
  cv::Mat l, rr;
  if (k == 1) {
    l = left(crop).clone();
    rr = right(crop).clone();
  } else {
    cv::resize(left(crop), l, cv::Size(r.width, r.height), 0, 0, cv::INTER_AREA);
    cv::resize(right(crop), rr, cv::Size(r.width, r.height), 0, 0, cv::INTER_AREA);
  }
  grey_pair(l, rr, left8, right8);
  if (!p.right_map_y.empty()) {
    cv::Mat aligned;
    cv::remap(right8, aligned, p.right_map_x, p.right_map_y, cv::INTER_LINEAR,
              cv::BORDER_REPLICATE);
    right8 = aligned;
  }
}

void ObstacleDetector::triangulate(const Pair& p, const cv::Mat& disparity, cv::Mat& points,
                                   bool ground_columns, const std::vector<bool>* columns) const {
  const camera::RectifiedCamera& grid = p.reduced.grid;
  const auto& r = grid.intrinsics();
  const Eigen::Vector3d& right_centre = p.reduced.right_centre_m;
  const bool on_axis = right_centre.isZero();
  const double A = p.reduced.baseline_m;
  const std::vector<double>&sin_a = p.sin_left, &cos_a = p.cos_left;
  const std::vector<double>&sin_r = p.sin_right, &cos_r = p.cos_right;
  const int steps = kRightSteps, first_step = p.first_right_step;
  if (points.size() != disparity.size() || points.type() != CV_32FC3) {
    points.create(disparity.size(), CV_32FC3);
    points.setTo(cv::Scalar::all(kNan));
  }
  const cv::Vec3f none(kNan, kNan, kNan);
  const int column_step = std::max(1, options_.ground.column_step);
  for (int row = 0; row < r.height; ++row) {
    const double beta = p.row_beta[static_cast<std::size_t>(row)];
    const double sb = std::sin(beta), cb = std::cos(beta);
    const auto* d = disparity.ptr<float>(row);
    auto* out = points.ptr<cv::Vec3f>(row);
    // Each pixel of the columns asked for is written, its point or NaN, so a buffer reused from
    // the last capture needs no reset.
    auto point = [&](int c) {
      if (columns != nullptr && !(*columns)[static_cast<std::size_t>(c)]) return;
      out[c] = none;
      if (!(d[c] > 0)) return;
      const auto i = static_cast<std::size_t>(c);
      const double right_column = c - d[c];
      const double step = right_column * steps - first_step;
      double sr, cr;
      if (step >= 0 && step < static_cast<double>(sin_r.size()) && step == std::floor(step)) {
        sr = sin_r[static_cast<std::size_t>(step)];
        cr = cos_r[static_cast<std::size_t>(step)];
      } else {
        const double a = grid.alpha_of_column(right_column);
        sr = std::abs(a) < M_PI / 2 ? std::sin(a) : kNan;
        cr = std::cos(a);
      }
      if (!std::isfinite(sr)) return;
      const Eigen::Vector3d u(sin_a[i], cos_a[i] * sb, cos_a[i] * cb);
      double B;
      if (on_axis) {
        const double s = sin_a[i] * cr - cos_a[i] * sr;  // sin(alpha_L - alpha_R)
        if (!(s > 1e-9)) return;
        B = A * cr / s;
      } else {
        B = range::distance_on_left_ray(u, right_centre, sr);
      }
      if (!(B > 0) || !std::isfinite(B)) return;
      out[c] = cv::Vec3f(static_cast<float>(B * u.x()), static_cast<float>(B * u.y()),
                         static_cast<float>(B * u.z()));
    };
    // The ground's columns (every column_step-th from 0) or those between them, stepped over
    // rather than tested with a modulo per pixel.
    for (int c0 = 0; c0 < r.width; c0 += column_step) {
      if (ground_columns) {
        point(c0);
        continue;
      }
      for (int c = c0 + 1; c < std::min(c0 + column_step, r.width); ++c) point(c);
    }
  }
}

std::vector<Stixel> ObstacleDetector::stixels(const Pair& p, const cv::Mat& disparity,
                                              const cv::Mat& points, const GroundPlane& ground,
                                              const GroundPlane& ground_reporting,
                                              std::vector<int>& ground_pixels,
                                              const std::vector<bool>* columns) const {
  const auto& r = p.reduced.grid.intrinsics();
  const double f_baseline = r.f * p.reduced.baseline_m;
  const int k = p.reduction;
  // Each pixel: whether it stands above the ground by more than min_height_m and 3 sigma of its
  // height's noise (its point moves along its ray by B^2 / (f A) per px: kStands), only by more
  // than min_height_m (kMayStand: a far pixel of a short object, or the road's noise); whether
  // it is on the ground (within min_height_m), counted per column for the free space.
  constexpr std::uint8_t kMayStand = 1, kStands = 2;
  PairScratch& scratch = scratch_for(p.setup.band);
  cv::Mat& stand = scratch.stand;
  stand.create(points.size(), CV_8U);  // every pixel written below
  ground_pixels.assign(static_cast<std::size_t>(r.width), 0);
  const Eigen::Vector3f n = ground.normal.cast<float>();
  const auto h = static_cast<float>(ground.height_m);
  const auto noise = static_cast<float>(3 * options_.disparity_sigma_px / f_baseline);
  const auto min_height = static_cast<float>(options_.min_height_m);
  for (int row = 0; row < r.height; ++row) {
    const auto* pv = points.ptr<cv::Vec3f>(row);
    auto* st = stand.ptr<std::uint8_t>(row);
    for (int c = 0; c < r.width; ++c) {
      if (columns != nullptr && !(*columns)[static_cast<std::size_t>(c)]) continue;
      const cv::Vec3f& P = pv[c];
      st[c] = 0;
      if (!std::isfinite(P[2])) continue;
      const float down = n.x() * P[0] + n.y() * P[1] + n.z() * P[2];
      const float height = h - down;
      if (height > min_height) {
        const float B = std::sqrt(P.dot(P));
        st[c] = height > min_height + std::abs(down) * B * noise ? kStands : kMayStand;
      } else if (height > -min_height) {
        ++ground_pixels[static_cast<std::size_t>(c)];
      }
    }
  }
  std::vector<Stixel> out;
  std::vector<std::pair<int, double>>& members = scratch.members;  // row, disparity
  std::vector<double>& ds = scratch.ds;
  int c = 0;
  // From `from` one row at a time by `step` (-1: up, +1: down), the pixels of at least `level`
  // at the running mean disparity of `members` (far ground rows differ little in disparity:
  // they are not a stixel), added to them; the last row taken and the mean.
  auto walk = [&](int from, int step, std::uint8_t level, double mean) {
    int gap = 0, last = from - step;
    for (int row = from; row >= 0 && row < r.height; row += step) {
      const float d = disparity.at<float>(row, c);
      const double tol = options_.stixel_tolerance_px + options_.stixel_tolerance_share * mean;
      if (d > 0 && std::abs(d - mean) <= tol && stand.at<std::uint8_t>(row, c) >= level) {
        members.emplace_back(row, d);
        mean += (d - mean) / static_cast<double>(members.size());
        gap = 0;
        last = row;
      } else if (++gap > options_.max_gap_rows) {
        break;
      }
    }
    return std::pair<int, double>(last, mean);
  };
  // From the candidate base `row` upwards, the pixels of at least `level`: the run's top row.
  auto collect = [&](int row, std::uint8_t level) {
    members.clear();
    return walk(row, -1, level, disparity.at<float>(row, c));
  };
  // The same run continued downwards over pixels at its disparity whatever their height (a
  // short object's lowest rows, within min_height_m of the ground); its base row.
  auto extend_down = [&](int row, double mean) { return walk(row + 1, 1, 0, mean).first; };
  enum class Verdict { stixel, not_standing, too_far };
  // The run of `members` from `row` up to `top` as a stixel, when it stands on the ground: its
  // base at its disparity is on the ground, give or take the height's noise, one row, and below
  // the ground the rows the matcher's block smears it down by (a false match floating over the
  // road is not; nor is the horizon's edge, whose disparity is an error of the edge's slope).
  // With `vertical`, also only when its disparity keeps to a vertical surface's along its rows
  // rather than the ground's (ObstacleOptions::vertical_max_share).
  auto make_stixel = [&](int row, int top, bool vertical, Stixel& s) {
    ds.clear();
    for (const auto& m : members) ds.push_back(m.second);
    const auto [d_med, deviation] = median_and_deviation(ds);
    const double spread = std::max(1.4826 * deviation, options_.disparity_sigma_px);
    Eigen::Vector3d top_p, mid_p, near_p, far_p, base_p;
    const double mid_row = 0.5 * (row + top);
    const double d_far = std::max(d_med - 0.5, 0.05);
    if (!point_at(p.reduced, c, row, d_med, base_p) || !point_at(p.reduced, c, top, d_med, top_p) ||
        !point_at(p.reduced, c, mid_row, d_med, mid_p) ||
        !point_at(p.reduced, c, mid_row, d_med + 0.5, near_p) ||
        !point_at(p.reduced, c, mid_row, d_far, far_p)) {
      return Verdict::not_standing;
    }
    const double sigma_d =
        std::sqrt(options_.systematic_disparity_px * options_.systematic_disparity_px +
                  spread * spread / static_cast<double>(members.size()));
    const double B = mid_p.norm();
    const double row_m = B / r.f;  // one reduced row at its distance
    const double sigma_h = B * B / f_baseline * sigma_d;
    const double foot = ground.height_of(base_p);
    const double height = ground.height_of(top_p);
    const double foot_noise = 3 * sigma_h * std::abs(ground.normal.dot(base_p)) / B;
    if (foot > options_.min_obstacle_height_m + row_m + foot_noise ||
        -foot > options_.min_obstacle_height_m + options_.foot_rows * row_m + foot_noise ||
        height <
            options_.min_obstacle_height_m + 3 * sigma_h * std::abs(ground.normal.dot(top_p)) / B) {
      return Verdict::not_standing;
    }
    if (vertical) {
      // The disparity the ground would gain from the run's top row down to its base (its
      // height there at the run's disparity over the height one px of disparity adds on the
      // ray), against what the run's own rows gain.
      const double per_d =
          (ground.height_of(near_p) - ground.height_of(far_p)) / (d_med + 0.5 - d_far);
      const double ground_gain = (height - foot) / per_d;
      // The run's own slope (Theil-Sen: the median of its pairs' slopes, which a stray row at
      // either end does not move).
      std::vector<double>& slopes = scratch.slopes;
      slopes.clear();
      for (std::size_t i = 0; i < members.size(); ++i) {
        for (std::size_t j = i + 1; j < members.size(); ++j) {
          if (members[i].first != members[j].first) {
            slopes.push_back((members[i].second - members[j].second) /
                             (members[i].first - members[j].first));
          }
        }
      }
      const double own_gain = slopes.empty() ? 0.0 : median_of(slopes) * (row - top);
      // A run reaching the horizon is not judged so: its rows above it have no ground to
      // differ from (the horizon's edge matched at one disparity over the block), and an
      // object that tall has rows enough that stand one by one.
      if (!(per_d > 0) || height >= ground.height_m ||
          ground_gain < options_.vertical_min_ground_gain_px ||
          std::abs(own_gain) > options_.vertical_max_share * ground_gain) {
        return Verdict::not_standing;
      }
    }
    s = Stixel{};
    s.column = c;
    s.base_row = (row + 1) * k - 1 + p.first_row;
    s.top_row = top * k + p.first_row;
    s.disparity_px = d_med;
    s.middle_m = p.T_reporting_rect * mid_p;
    s.distance_m = horizontal_distance(s.middle_m, ground_reporting.normal);
    if (s.distance_m > options_.max_distance_m) return Verdict::too_far;
    const double per_px =
        std::abs(horizontal_distance(p.T_reporting_rect * far_p, ground_reporting.normal) -
                 horizontal_distance(p.T_reporting_rect * near_p, ground_reporting.normal));
    s.sigma_m = per_px * sigma_d;
    s.height_m = height;
    return Verdict::stixel;
  };
  // min_stixel_rows of the reduced grid's rows, on a finer one (the far band) as many more.
  const int min_rows = options_.min_stixel_rows * options_.reduction / k;
  // The fitted ground's horizon (its row's elevation is the plane's, rows being elevations).
  const double horizon_row = r.cy + r.f * std::atan2(-ground.normal.z(), ground.normal.y());
  for (c = 0; c < r.width; ++c) {
    if (columns != nullptr && !(*columns)[static_cast<std::size_t>(c)]) continue;
    // The column's first run from the bottom whose pixels stand one by one.
    Stixel found;
    int found_row = -1;  // reduced row of its base (-1: none)
    for (int row = r.height - 1; row >= 0; --row) {
      if (!(disparity.at<float>(row, c) > 0) || stand.at<std::uint8_t>(row, c) != kStands) continue;
      const int top = collect(row, kStands).first;
      if (static_cast<int>(members.size()) < min_rows) continue;
      const Verdict v = make_stixel(row, top, false, found);
      if (v == Verdict::stixel) found_row = row;
      if (v != Verdict::not_standing) break;  // the column's first obstacle only
      row = top;
    }
    // Where there is none, the first run whose pixels only may stand one by one but whose
    // disparity is a vertical surface's as a whole: a short object whose height is within its
    // pixels' noise (a 0.5 m box at 20-30 m). Not below a stixel found: a column has one, and
    // such a run under a farther object (the parked car's lower rear under the 35 m pole) hid
    // the object in more columns than it found new ones.
    if (options_.vertical_max_share > 0 && found_row < 0) {
      const int min_span = options_.dense.block_size + options_.vertical_min_rows_beyond_block;
      // Nearer than vertical_min_distance_m the pixels of anything min_obstacle_height_m tall
      // stand one by one: the runs left there are the mixed blocks at an object's sides.
      const double max_ground_rows =
          r.f * std::atan2(ground.height_m, options_.vertical_min_distance_m);
      // So no run's base lies lower than the ground that far away (two rows for the ground's
      // roll across the grid).
      const int lowest =
          std::min(r.height - 1, static_cast<int>(horizon_row + max_ground_rows) + 2);
      for (int row = lowest; row >= 0; --row) {
        if (!(disparity.at<float>(row, c) > 0) || stand.at<std::uint8_t>(row, c) == 0) continue;
        const auto [top, mean] = collect(row, kMayStand);
        const int base = extend_down(row, mean);
        Verdict v = Verdict::not_standing;
        Stixel s;
        Eigen::Vector3d at;
        if (base - top + 1 >= min_span && static_cast<int>(members.size()) >= min_rows &&
            point_at(p.reduced, c, base, mean, at)) {
          // The ground at the run's distance this many rows below the horizon (rows are
          // angles of elevation).
          const double distance = horizontal_distance(at, ground.normal);
          const double ground_rows = r.f * std::atan2(ground.height_m, distance);
          if (ground_rows >= options_.vertical_min_rows_below_horizon &&
              ground_rows <= max_ground_rows && distance <= options_.vertical_max_distance_m) {
            v = make_stixel(base, top, true, s);
          }
        }
        if (v == Verdict::too_far) break;
        if (v == Verdict::stixel) {
          found = s;
          found_row = base;
          break;
        }
        row = top;  // the next candidate above this run
      }
    }
    if (found_row >= 0) out.push_back(found);
  }
  return out;
}

std::vector<Obstacle> ObstacleDetector::cluster(const std::vector<Stixel>& stixels, PairBand band,
                                                const GroundPlane& ground_reporting,
                                                std::vector<std::pair<int, int>>& spans) const {
  std::vector<Obstacle> out;
  const int k = options_.reduction;
  std::size_t start = 0;
  auto close = [&](std::size_t begin, std::size_t end) {
    if (static_cast<int>(end - begin) < options_.min_obstacle_columns) return;
    Obstacle o;
    o.bands = band_bit(band);
    o.stixels = static_cast<int>(end - begin);
    const Stixel& nearest = nearest_stixel(stixels, begin, end);
    int x0 = grid_.width, x1 = 0, y0 = grid_.height, y1 = 0;
    double far = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const Stixel& s = stixels[i];
      far = std::max(far, s.distance_m);
      x0 = std::min(x0, s.column * k);
      x1 = std::max(x1, (s.column + 1) * k - 1);
      y0 = std::min(y0, s.top_row);
      y1 = std::max(y1, s.base_row);
      o.position_m += s.middle_m;
      o.extent_m.y() = std::max(o.extent_m.y(), s.height_m);
    }
    o.position_m /= static_cast<double>(o.stixels);
    const Eigen::Vector3d& n = ground_reporting.normal;
    const Eigen::Vector3d across = stixels[end - 1].middle_m - stixels[begin].middle_m;
    o.extent_m.x() = (across - n.dot(across) * n).norm();
    o.extent_m.z() = far - nearest.distance_m;
    // The near face, at its median.
    std::vector<double> near_face, near_sigma;
    for (std::size_t i = begin; i < end; ++i) {
      if (stixels[i].distance_m <= near_face_limit_m(nearest)) {
        near_face.push_back(stixels[i].distance_m);
        near_sigma.push_back(stixels[i].sigma_m);
      }
    }
    o.distance_m = median_of(near_face);
    o.sigma_m = median_of(near_sigma) / std::sqrt(static_cast<double>(near_face.size()));
    o.box = cv::Rect(cv::Point(x0, y0), cv::Point(x1 + 1, y1 + 1));
    // Too far to range: one stixel's sigma over max_sigma_share of the distance.
    if (nearest.sigma_m > options_.max_sigma_share * o.distance_m) return;
    spans.emplace_back(static_cast<int>(begin), static_cast<int>(end));
    out.push_back(o);
  };
  const auto tolerance = [&](double a_m, double b_m) {
    return same_obstacle_within_m(options_, std::min(a_m, b_m));
  };
  for (std::size_t i = 1; i <= stixels.size(); ++i) {
    if (i < stixels.size()) {
      const Stixel& a = stixels[i - 1];
      const Stixel& b = stixels[i];
      // Near its neighbour, and near the median of the obstacle's last five stixels: the one or
      // two mixed stixels where a nearer object covers part of a farther one (blocks straddling
      // both) range in between and would otherwise chain the two into one.
      // Kept in order as they are taken (at most five: std::sort on the part of the array in
      // use made GCC 12 warn of bounds it cannot see are kept).
      std::array<double, 5> last{};
      std::size_t n = 0;
      for (std::size_t j = i; j > start && n < last.size(); --j) {
        const double v = stixels[j - 1].distance_m;
        std::size_t at = n++;
        for (; at > 0 && last[at - 1] > v; --at) last[at] = last[at - 1];
        last[at] = v;
      }
      const double recent_m = last[n / 2];
      if (b.column - a.column - 1 <= options_.max_cluster_gap_columns &&
          std::abs(a.distance_m - b.distance_m) <= tolerance(a.distance_m, b.distance_m) &&
          std::abs(recent_m - b.distance_m) <= tolerance(recent_m, b.distance_m)) {
        continue;
      }
    }
    close(start, i);
    start = i;
  }
  return out;
}

GroundTracker& GroundTracks::of(PairBand band) {
  for (auto& [b, tracker] : trackers_) {
    if (b == band) return tracker;
  }
  trackers_.emplace_back(band, GroundTracker(options_));
  return trackers_.back().second;
}

void GroundTracks::reset() {
  for (auto& entry : trackers_) entry.second.reset();
}

PairObstacles ObstacleDetector::from_disparity(PairBand band, const cv::Mat& disparity,
                                               const GroundPlane* rig_ground) const {
  return analyse(band, disparity, rig_ground, nullptr);
}

PairObstacles ObstacleDetector::analyse(PairBand band, const cv::Mat& disparity,
                                        const GroundPlane* rig_ground,
                                        GroundTracker* tracker) const {
  const Pair& p = pair(band);
  const auto& r = p.reduced.grid.intrinsics();
  if (disparity.type() != CV_32FC1 || disparity.size() != cv::Size(r.width, r.height)) {
    throw std::invalid_argument("obstacles: the " + band_name(band) + " disparity is not " +
                                std::to_string(r.width) + "x" + std::to_string(r.height) +
                                " CV_32FC1 (the reduced grid)");
  }
  PairObstacles out;
  out.band = band;
  out.free_space_m.assign(static_cast<std::size_t>(grid_.width), kNan);
  // The columns the ground is fitted on first; the others only when there is a ground.
  cv::Mat& points = scratch_for(band).points;
  triangulate(p, disparity, points, true);
  if (rig_ground != nullptr) {
    out.ground.status = GroundStatus::ok;
    out.ground.message = "the other pair's ground";
    out.ground.plane = plane_in_frame(*rig_ground, p.setup.geometry.T_ref_left_rect);
    out.ground_from_other = true;
  } else {
    const double f_baseline = r.f * p.reduced.baseline_m;
    if (tracker != nullptr && tracker->tracking()) {
      // About the last frame's ground; the prior's search where that finds none or one the
      // prior's search would not have accepted.
      out.ground = fit_ground(points, p.row_beta, f_baseline, tracker->centre(p.prior),
                              tracker->search_options(options_.ground));
      out.ground_tracked =
          out.ground.ok() && within_search(out.ground.plane, p.prior, options_.ground);
    }
    if (!out.ground_tracked) {
      out.ground = fit_ground(points, p.row_beta, f_baseline, p.prior, options_.ground);
    }
    if (tracker != nullptr) tracker->update(out.ground);
  }
  const Eigen::Isometry3d T_rect_reporting = p.T_reporting_rect.inverse();
  out.ground_reporting = plane_in_frame(out.ground.plane, T_rect_reporting);
  if (!out.ground.ok()) return out;
  triangulate(p, disparity, points, false);

  std::vector<int> ground_pixels;
  out.stixels =
      stixels(p, disparity, points, out.ground.plane, out.ground_reporting, ground_pixels);
  out.obstacles = cluster(out.stixels, band, out.ground_reporting, out.obstacle_stixels);
  // Free space per reduced column: its kept stixel's distance; the farthest range where the
  // column holds the ground and no obstacle; unknown (NaN) where it holds neither.
  std::vector<float> reduced(static_cast<std::size_t>(r.width), kNan);
  for (int c = 0; c < r.width; ++c) {
    if (ground_pixels[static_cast<std::size_t>(c)] >= options_.min_stixel_rows) {
      reduced[static_cast<std::size_t>(c)] = static_cast<float>(options_.max_distance_m);
    }
  }
  for (const auto& [begin, end] : out.obstacle_stixels) {
    for (int i = begin; i < end; ++i) {
      const Stixel& s = out.stixels[static_cast<std::size_t>(i)];
      reduced[static_cast<std::size_t>(s.column)] = static_cast<float>(s.distance_m);
    }
  }
  for (int x = 0; x < grid_.width; ++x) {
    out.free_space_m[static_cast<std::size_t>(x)] =
        reduced[static_cast<std::size_t>(std::min(x / options_.reduction, r.width - 1))];
  }
  return out;
}

namespace {

// A pair off the grid's axis after its right image was resampled onto the left's rows at the
// prior ground's distance (Pair::right_map_y): a point nearer than that ground (an object's
// upper part) is still `delta` rows off in the right image, and block matching along the rows
// reads a block whose gradient is oblique shifted by delta * sum(gx gy) / sum(gx^2) (the least
// squares shift of a linear patch moved by delta down the rows). Per pixel, delta follows from
// its own disparity (row_per_disparity * d: the row offset falls as 1 / distance, as the
// disparity grows) less the map's; the disparity is corrected by it. Blocks whose gradient runs
// mostly down the rows (x Sobel magnitude under `share` of the y Sobel's: the horizon, a road's
// far edge, tilted a degree or two on the grid) are dropped, where a tenth of a pixel of row
// offset moves the match by pixels; so is a correction of more than max_px.
void correct_off_axis(const cv::Mat& left8, int block, double share, double max_px,
                      const cv::Mat& row_per_disparity, const cv::Mat& map_y, cv::Mat& disparity) {
  // The gradients and the block sums in integers (exact: a 3 x 3 Sobel of 8-bit grey is under
  // 2^11, the sum of 49 products under 2^26), as float where they are compared.
  cv::Mat gx, gy;
  cv::spatialGradient(left8, gx, gy, 3, cv::BORDER_REFLECT_101);  // CV_16S
  cv::Mat terms(left8.size(), CV_32SC4), sums;
  for (int r = 0; r < left8.rows; ++r) {
    const auto* x = gx.ptr<short>(r);
    const auto* y = gy.ptr<short>(r);
    auto* t = terms.ptr<cv::Vec4i>(r);
    for (int c = 0; c < left8.cols; ++c) {
      t[c] = cv::Vec4i(std::abs(x[c]), std::abs(y[c]), x[c] * x[c], x[c] * y[c]);
    }
  }
  cv::boxFilter(terms, sums, CV_32S, cv::Size(block, block), cv::Point(-1, -1), false,
                cv::BORDER_REFLECT_101);
  const auto s = static_cast<float>(share);
  std::vector<float> x(static_cast<std::size_t>(disparity.cols)), y(x.size()), sxx(x.size()),
      sxy(x.size());
  for (int r = 0; r < disparity.rows; ++r) {
    const auto* sum = sums.ptr<cv::Vec4i>(r);
    for (int c = 0; c < disparity.cols; ++c) {
      const auto i = static_cast<std::size_t>(c);
      x[i] = static_cast<float>(sum[c][0]);
      y[i] = static_cast<float>(sum[c][1]);
      sxx[i] = static_cast<float>(sum[c][2]);
      sxy[i] = static_cast<float>(sum[c][3]);
    }
    const auto* k = row_per_disparity.ptr<float>(r);
    const auto* my = map_y.ptr<float>(r);
    auto* d = disparity.ptr<float>(r);
    for (int c = 0; c < disparity.cols; ++c) {
      if (!(d[c] > 0)) continue;
      if (x[c] < s * y[c] || !(sxx[c] > 0)) {
        d[c] = kNan;
        continue;
      }
      if (max_px < 0) continue;
      const float delta = k[c] * d[c] - (my[c] - static_cast<float>(r));
      const float correction = delta * sxy[c] / sxx[c];
      d[c] = std::abs(correction) <= max_px && d[c] + correction > 0 ? d[c] + correction : kNan;
    }
  }
}

}  // namespace

DenseOptions ObstacleDetector::dense_options_for(const cv::Mat& left) const {
  DenseOptions o = options_.dense;
  if (left.type() == CV_16UC1) o.texture_noise_factor = options_.counts_texture_noise_factor;
  return o;
}

cv::Mat ObstacleDetector::disparity(PairBand band, const cv::Mat& left,
                                    const cv::Mat& right) const {
  cv::Mat left8, right8;
  reduce_pair(band, left, right, left8, right8);
  DenseOptions dense = dense_options_for(left);
  if (dense.method == DenseMethod::block_matching) {
    // The texture threshold (its noise estimate a filter over the whole image) once, for both
    // textured_share and the matcher, which would each measure it again: the same threshold.
    dense.texture_threshold = block_texture_threshold(left8, dense);
    dense.texture_noise_factor = 0;
  }
  // Block matching gives a disparity to no more pixels than have a block with texture: where
  // that is less than the ground fit needs (min_valid_share, then no_disparity), not matched
  // (on the simulated empty road at night the infrared pair's).
  if (dense.method == DenseMethod::block_matching &&
      textured_share(left8, dense) < options_.ground.min_valid_share) {
    return cv::Mat(left8.size(), CV_32FC1, cv::Scalar(kNan));
  }
  if (!pair(band).right_map_y.empty()) dense.uniqueness_ratio = options_.off_axis_uniqueness_ratio;
  cv::Mat d = dense_disparity(left8, right8, max_disparity_px_, dense);
  const Pair& p = pair(band);
  if (!p.right_map_y.empty()) {
    correct_off_axis(left8, dense.block_size, options_.off_axis_min_across_share,
                     options_.off_axis_max_correction_px, p.right_row_per_disparity, p.right_map_y,
                     d);
  }
  return d;
}

PairObstacles ObstacleDetector::detect_pair(PairBand band, const cv::Mat& left,
                                            const cv::Mat& right) const {
  PairObstacles out = from_disparity(band, disparity(band, left, right));
  add_far_band(pair(band), left, right, out);
  refine(pair(band), left, right, out);
  return out;
}

PairObstacles ObstacleDetector::detect_pair(PairBand band, const cv::Mat& left,
                                            const cv::Mat& right, GroundTracker& tracker) const {
  PairObstacles out = analyse(band, disparity(band, left, right), nullptr, &tracker);
  add_far_band(pair(band), left, right, out);
  refine(pair(band), left, right, out);
  return out;
}

ObstacleResult ObstacleDetector::detect(const cv::Mat& visible_left, const cv::Mat& visible_right,
                                        const cv::Mat& infrared_left,
                                        const cv::Mat& infrared_right) const {
  return detect_with(visible_left, visible_right, infrared_left, infrared_right, nullptr);
}

ObstacleResult ObstacleDetector::detect(const cv::Mat& visible_left, const cv::Mat& visible_right,
                                        const cv::Mat& infrared_left, const cv::Mat& infrared_right,
                                        GroundTracks& tracks) const {
  return detect_with(visible_left, visible_right, infrared_left, infrared_right, &tracks);
}

ObstacleResult ObstacleDetector::detect_with(const cv::Mat& visible_left,
                                             const cv::Mat& visible_right,
                                             const cv::Mat& infrared_left,
                                             const cv::Mat& infrared_right,
                                             GroundTracks* tracks) const {
  std::vector<std::pair<PairBand, cv::Mat>> disparities;
  std::vector<std::pair<const cv::Mat*, const cv::Mat*>> images;
  for (const Pair& p : pairs_) {
    const bool visible = p.setup.band == PairBand::visible;
    const cv::Mat& l = visible ? visible_left : infrared_left;
    const cv::Mat& r = visible ? visible_right : infrared_right;
    if (l.empty() && r.empty()) continue;
    disparities.emplace_back(p.setup.band, disparity(p.setup.band, l, r));
    images.emplace_back(&l, &r);
  }
  std::vector<PairObstacles> found = analyse_pairs(disparities, tracks);
  for (std::size_t i = 0; i < found.size(); ++i) {
    add_far_band(pair(found[i].band), *images[i].first, *images[i].second, found[i]);
    refine(pair(found[i].band), *images[i].first, *images[i].second, found[i]);
  }
  return combine(std::move(found));
}

ObstacleResult ObstacleDetector::from_disparities(
    const std::vector<std::pair<PairBand, cv::Mat>>& disparities) const {
  return from_disparities_with(disparities, nullptr);
}

ObstacleResult ObstacleDetector::from_disparities(
    const std::vector<std::pair<PairBand, cv::Mat>>& disparities, GroundTracks& tracks) const {
  return from_disparities_with(disparities, &tracks);
}

ObstacleResult ObstacleDetector::from_disparities_with(
    const std::vector<std::pair<PairBand, cv::Mat>>& disparities, GroundTracks* tracks) const {
  return combine(analyse_pairs(disparities, tracks));
}

std::vector<PairObstacles> ObstacleDetector::analyse_pairs(
    const std::vector<std::pair<PairBand, cv::Mat>>& disparities, GroundTracks* tracks) const {
  std::vector<PairObstacles> found;
  for (const auto& [band, d] : disparities) {
    found.push_back(analyse(band, d, nullptr, tracks != nullptr ? &tracks->of(band) : nullptr));
  }
  // A pair without a ground of its own on the other's (in the rig frame).
  for (std::size_t i = 0; i < found.size() && options_.share_ground; ++i) {
    if (found[i].ok()) continue;
    for (std::size_t j = 0; j < found.size(); ++j) {
      if (j == i || !found[j].ok() || found[j].ground_from_other) continue;
      const GroundPlane rig_ground = plane_in_frame(
          found[j].ground.plane, pair(found[j].band).setup.geometry.T_ref_left_rect.inverse());
      const GroundFit own = found[i].ground;
      found[i] = from_disparity(found[i].band, disparities[i].second, &rig_ground);
      found[i].ground.message += " (its own: " + status_name(own.status) + ", " + own.message + ")";
      break;
    }
  }
  return found;
}

void ObstacleDetector::add_far_band(const Pair& p, const cv::Mat& left, const cv::Mat& right,
                                    PairObstacles& out) const {
  const int type = left.type();
  if (!far_band_ || p.setup.band != far_band_->setup.band || !out.ok() ||
      left.size() != cv::Size(grid_.width, grid_.height) || right.size() != left.size() ||
      right.type() != type || (type != CV_8UC1 && type != CV_8UC3)) {
    return;
  }
  // The rows: from a block above the fitted ground's horizon (what stands on the ground beyond
  // far_band_min_distance_m and is under the camera's height is below it) down to that
  // ground's row, the block's smear and the rows a stixel's foot may reach below it.
  const GroundPlane& ground = out.ground.plane;
  const double beta_horizon = std::atan2(-ground.normal.z(), ground.normal.y());
  const int block = options_.dense.block_size;
  const int first =
      std::max(0, static_cast<int>(std::floor(grid_.cy + grid_.f * beta_horizon)) - 2 * block);
  const int last = std::min(
      grid_.height,
      static_cast<int>(std::ceil(
          grid_.cy + grid_.f * (beta_horizon +
                                std::atan2(ground.height_m, options_.far_band_min_distance_m)))) +
          static_cast<int>(options_.foot_rows) + 2 * block);
  if (last - first < 4 * block) return;
  Pair band = *far_band_;
  band.first_row = first;
  camera::RectifiedIntrinsics r = grid_;
  r.height = last - first;
  r.cy = grid_.cy - first;
  band.reduced.grid = camera::RectifiedCamera(r);
  band.row_beta.resize(static_cast<std::size_t>(r.height));
  for (int row = 0; row < r.height; ++row) {
    band.row_beta[static_cast<std::size_t>(row)] = (row - r.cy) / r.f;
  }
  const cv::Rect rows(0, first, grid_.width, r.height);
  cv::Mat left8, right8;
  grey_pair(left(rows), right(rows), left8, right8);
  DenseOptions dense = options_.dense;
  dense.texture_threshold = block_texture_threshold(left8, dense);
  dense.texture_noise_factor = 0;
  const cv::Mat disparity = dense_disparity(
      left8, right8, range::max_disparity_for(band.reduced, options_.far_band_min_distance_m),
      dense);
  // Only the grid columns of reduced columns without a stixel.
  const int k = options_.reduction;
  const int width = grid_.width / k;
  std::vector<bool> columns(static_cast<std::size_t>(grid_.width), true);
  for (const Stixel& s : out.stixels) {
    for (int x = s.column * k; x < std::min((s.column + 1) * k, grid_.width); ++x) {
      columns[static_cast<std::size_t>(x)] = false;
    }
  }
  thread_local cv::Mat points;
  triangulate(band, disparity, points, true, &columns);
  triangulate(band, disparity, points, false, &columns);
  std::vector<int> ground_pixels;
  const std::vector<Stixel> found =
      stixels(band, disparity, points, ground, out.ground_reporting, ground_pixels, &columns);
  // The nearest of each reduced column's grid columns, when a second of the grid columns from
  // one before to one after them has one at about its distance (one grid column alone was the
  // horizon's edge over the far road: 2 false obstacles per 100 empty-road frames).
  std::vector<int> at_column(static_cast<std::size_t>(grid_.width), -1);
  for (std::size_t i = 0; i < found.size(); ++i) {
    const Stixel& s = found[i];
    if (s.distance_m >= options_.far_band_min_distance_m &&
        s.distance_m <= options_.far_band_max_distance_m) {
      at_column[static_cast<std::size_t>(s.column)] = static_cast<int>(i);
    }
  }
  std::vector<bool> added(static_cast<std::size_t>(width), false);
  for (int c = 0; c < width; ++c) {
    int at = -1;
    for (int x = c * k; x < (c + 1) * k; ++x) {
      const int i = at_column[static_cast<std::size_t>(x)];
      if (i >= 0 && (at < 0 || found[static_cast<std::size_t>(i)].disparity_px >
                                   found[static_cast<std::size_t>(at)].disparity_px)) {
        at = i;
      }
    }
    if (at < 0) continue;
    const double d = found[static_cast<std::size_t>(at)].distance_m;
    int alike = 0;
    for (int x = std::max(0, c * k - 1); x < std::min(grid_.width, (c + 1) * k + 1); ++x) {
      const int i = at_column[static_cast<std::size_t>(x)];
      alike += i >= 0 && std::abs(found[static_cast<std::size_t>(i)].distance_m - d) <=
                             same_obstacle_within_m(options_, d);
    }
    if (alike < 2) continue;
    Stixel s = found[static_cast<std::size_t>(at)];
    s.column = c;
    s.disparity_px /= k;  // reduced px, as the others'
    out.stixels.push_back(s);
    added[static_cast<std::size_t>(c)] = true;
  }
  if (std::none_of(added.begin(), added.end(), [](bool a) { return a; })) return;
  std::stable_sort(out.stixels.begin(), out.stixels.end(),
                   [](const Stixel& a, const Stixel& b) { return a.column < b.column; });
  out.obstacle_stixels.clear();
  out.obstacles = cluster(out.stixels, p.setup.band, out.ground_reporting, out.obstacle_stixels);
  // The free space of the columns now in an obstacle: its stixel's distance.
  for (const auto& [begin, end] : out.obstacle_stixels) {
    for (int i = begin; i < end; ++i) {
      const Stixel& s = out.stixels[static_cast<std::size_t>(i)];
      if (!added[static_cast<std::size_t>(s.column)]) continue;
      for (int x = s.column * k; x < std::min((s.column + 1) * k, grid_.width); ++x) {
        out.free_space_m[static_cast<std::size_t>(x)] = static_cast<float>(s.distance_m);
      }
    }
  }
}

void ObstacleDetector::refine(const Pair& p, const cv::Mat& left, const cv::Mat& right,
                              PairObstacles& out) const {
  // On the pair's own 8-bit images at the grid's resolution, `reduction` times finer than the
  // stixels' disparity: the visible pair. (The infrared pair keeps its stixels' distances: its
  // region, a warm body's silhouette, aligns at the body's axis, farther than its nearest
  // point, and on the simulated night road it moved no error towards 0.)
  const int type = left.type();
  if (!options_.refine || !out.ok() || p.setup.image_reduction != 1 ||
      left.size() != right.size() || right.type() != type || (type != CV_8UC1 && type != CV_8UC3)) {
    return;
  }
  const int k = options_.reduction;
  match::RegionOptions region;
  region.search_radius_px = 2;
  region.max_pixels = 400;  // a narrow face holds a few hundred: more are subsampled
  region.max_disparity_px = (max_disparity_px_ + 2) * k;
  std::vector<double> ds;
  for (std::size_t i = 0; i < out.obstacles.size(); ++i) {
    Obstacle& o = out.obstacles[i];
    if (o.distance_m < options_.refine_min_distance_m) continue;
    const auto [begin, end] = out.obstacle_stixels[i];
    // Its near face (the stixels its distance is the median of) as one region of the grid:
    // each stixel's reduced column and its rows.
    const double reach_m = near_face_limit_m(nearest_stixel(
        out.stixels, static_cast<std::size_t>(begin), static_cast<std::size_t>(end)));
    const auto column_of = [&](const Stixel& st) {
      return cv::Rect(st.column * k, st.top_row, k, st.base_row - st.top_row + 1);
    };
    cv::Rect box;
    ds.clear();
    for (int j = begin; j < end; ++j) {
      const Stixel& st = out.stixels[static_cast<std::size_t>(j)];
      if (st.distance_m > reach_m) continue;
      box |= column_of(st);
      ds.push_back(st.disparity_px);
    }
    box &= cv::Rect(0, 0, left.cols, left.rows);
    if (box.empty() || static_cast<int>(ds.size()) > options_.refine_max_columns) continue;
    cv::Mat mask = cv::Mat::zeros(box.size(), CV_8UC1);
    for (int j = begin; j < end; ++j) {
      const Stixel& st = out.stixels[static_cast<std::size_t>(j)];
      if (st.distance_m <= reach_m) mask((column_of(st) & box) - box.tl()).setTo(255);
    }
    const double initial_px = median_of(ds) * k;
    // Both eyes cut to the part the alignment reads: the box, the search to its left in the
    // right eye, a margin for the interpolation (grey: views; colour: only that part converted).
    const int reach = static_cast<int>(std::ceil(initial_px)) + region.search_radius_px + 8;
    const cv::Rect part =
        cv::Rect(box.x - reach, box.y - 8, box.width + reach + 8, box.height + 16) &
        cv::Rect(0, 0, left.cols, left.rows);
    cv::Mat grey_left = left(part), grey_right = right(part);
    if (type == CV_8UC3) {
      cv::cvtColor(left(part), grey_left, cv::COLOR_BGR2GRAY);
      cv::cvtColor(right(part), grey_right, cv::COLOR_BGR2GRAY);
    }
    const match::RegionDisparity r =
        match::align_region(grey_left, grey_right, box - part.tl(), mask, initial_px, region);
    if (!r.ok() || !(std::abs(r.disparity_px - initial_px) <= options_.refine_max_change_px)) {
      continue;
    }
    const Eigen::Vector2d anchor = r.anchor + Eigen::Vector2d(part.x, part.y);
    const range::PointTriangulation t =
        range::triangulate(p.setup.geometry, anchor, r.disparity_px);
    if (!t.valid) continue;
    const double distance_m =
        horizontal_distance(p.T_reporting_rect * t.position_left_rect, out.ground_reporting.normal);
    // Horizontal metres per px of disparity: the ray's (distance_per_px) scaled to the ground.
    const double per_px = t.distance_per_px * distance_m / t.distance_m;
    o.distance_m = distance_m;
    o.sigma_m = per_px * std::hypot(r.sigma_px, options_.refine_systematic_px);
  }
}

ObstacleResult ObstacleDetector::combine(std::vector<PairObstacles> pairs) const {
  ObstacleResult out;
  out.pairs = std::move(pairs);
  out.free_space_m.assign(static_cast<std::size_t>(grid_.width), kNan);
  for (const PairObstacles& p : out.pairs) {
    if (!p.ok()) continue;
    for (std::size_t x = 0; x < out.free_space_m.size(); ++x) {
      const float v = p.free_space_m[x];
      if (std::isfinite(v) && !(out.free_space_m[x] <= v)) out.free_space_m[x] = v;
    }
    for (const Obstacle& o : p.obstacles) {
      // The same obstacle seen by the other pair: boxes overlapping by a third of the smaller
      // and distances within 3 sigma (+ 5 %).
      Obstacle* same = nullptr;
      for (Obstacle& q : out.obstacles) {
        if ((q.bands & o.bands) != 0) continue;
        const double overlap = (q.box & o.box).area();
        const double sigma = std::hypot(q.sigma_m, o.sigma_m);
        if (overlap > std::min(q.box.area(), o.box.area()) / 3.0 &&
            std::abs(q.distance_m - o.distance_m) <= 3 * sigma + 0.05 * o.distance_m) {
          same = &q;
          break;
        }
      }
      if (same == nullptr) {
        out.obstacles.push_back(o);
        continue;
      }
      const double wa = 1.0 / std::max(1e-12, same->sigma_m * same->sigma_m);
      const double wb = 1.0 / std::max(1e-12, o.sigma_m * o.sigma_m);
      same->distance_m = (wa * same->distance_m + wb * o.distance_m) / (wa + wb);
      same->sigma_m = 1.0 / std::sqrt(wa + wb);
      same->position_m = (wa * same->position_m + wb * o.position_m) / (wa + wb);
      same->extent_m = same->extent_m.cwiseMax(o.extent_m);
      same->box |= o.box;
      same->bands |= o.bands;
      same->stixels += o.stixels;
    }
  }
  std::sort(out.obstacles.begin(), out.obstacles.end(),
            [](const Obstacle& a, const Obstacle& b) { return a.distance_m < b.distance_m; });
  return out;
}

}  // namespace thermovis::obstacle
