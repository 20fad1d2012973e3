#include "thermovis/range/ranging.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <random>
#include <sstream>
#include <tuple>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::range {

namespace {

constexpr util::EnumName<RangeStatus> kStatusNames[] = {
    {RangeStatus::ok, "ok"},
    {RangeStatus::empty_box, "empty_box"},
    {RangeStatus::box_outside_image, "box_outside_image"},
    {RangeStatus::target_at_image_edge, "target_at_image_edge"},
    {RangeStatus::no_matches, "no_matches"},
    {RangeStatus::too_few_points, "too_few_points"},
    {RangeStatus::no_region, "no_region"}};

// A correspondence's angles: alpha of each eye's column, beta of the row; false when one is
// outside the grid's domain.
bool correspondence_angles(const camera::RectifiedCamera& grid, const Eigen::Vector2d& left_px,
                           double right_column, PointTriangulation& t) {
  t.alpha_left = grid.alpha_of_column(left_px.x());
  t.alpha_right = grid.alpha_of_column(right_column);
  const auto& g = grid.intrinsics();
  t.beta = (left_px.y() - g.cy) / g.f;
  const double half_pi = M_PI / 2;
  return std::abs(t.alpha_left) < half_pi && std::abs(t.alpha_right) < half_pi &&
         std::abs(t.beta) < M_PI;
}

}  // namespace

PointTriangulation triangulate(const camera::RectifiedCamera& grid, double baseline_m,
                               const Eigen::Vector2d& left_px, double disparity_px) {
  PointTriangulation t;
  if (!left_px.allFinite() || !std::isfinite(disparity_px) || !(disparity_px > 0.0) ||
      !(baseline_m > 0.0)) {
    return t;
  }
  const double right_column = left_px.x() - disparity_px;
  if (!correspondence_angles(grid, left_px, right_column, t)) return t;
  // Eq. 31-32: theta = pi/2 - alpha; B = A sin(theta_R) / sin(theta_R - theta_L).
  const double angle_at_target = t.alpha_left - t.alpha_right;  // theta_R - theta_L
  const double s = std::sin(angle_at_target);
  if (!(s > 1e-12)) return t;
  t.distance_m = baseline_m * std::cos(t.alpha_right) / s;
  // Eq. 33: depth = B sin(theta_L) cos(beta).
  t.depth_m = t.distance_m * std::cos(t.alpha_left) * std::cos(t.beta);
  t.position_left_rect = t.distance_m * Eigen::Vector3d(std::sin(t.alpha_left),
                                                        std::cos(t.alpha_left) * std::sin(t.beta),
                                                        std::cos(t.alpha_left) * std::cos(t.beta));
  // dB/d(alpha_R) = A cos(alpha_L) / sin^2(alpha_L - alpha_R); d(alpha_R)/d(disparity) is the
  // grid's angle per column at the right pixel (1/f for equirectangular).
  const double alpha_per_px =
      grid.alpha_of_column(right_column + 0.5) - grid.alpha_of_column(right_column - 0.5);
  t.distance_per_px = baseline_m * std::cos(t.alpha_left) / (s * s) * alpha_per_px;
  t.valid = std::isfinite(t.distance_m) && t.distance_m > 0;
  return t;
}

double distance_on_left_ray(const Eigen::Vector3d& u, const Eigen::Vector3d& c,
                            double sin_alpha_right) {
  // P = B u with (P - c).x = sin(alpha_R) |P - c|; squared, a quadratic in B. Of its roots the
  // one in front (B > 0) on the right side of the right eye (the sign of sin(alpha_R)).
  const double s = sin_alpha_right, s2 = s * s;
  const double a = u.x() * u.x() - s2;
  const double b = -2.0 * (u.x() * c.x() - s2 * u.dot(c));
  const double q = c.x() * c.x() - s2 * c.squaredNorm();
  double roots[2];
  int n = 0;
  if (std::abs(a) < 1e-15) {
    if (std::abs(b) > 0) roots[n++] = -q / b;
  } else {
    const double disc = b * b - 4 * a * q;
    if (disc >= 0) {
      roots[n++] = (-b + std::sqrt(disc)) / (2 * a);
      roots[n++] = (-b - std::sqrt(disc)) / (2 * a);
    }
  }
  double best = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < n; ++i) {
    const double B = roots[i];
    if (!(B > 0) || !std::isfinite(B)) continue;
    const Eigen::Vector3d r = B * u - c;
    if (std::abs(r.x() / r.norm() - s) > 1e-9 + 1e-6 * std::abs(s)) continue;  // squaring's root
    if (std::isnan(best) || B < best) best = B;
  }
  return best;
}

PointTriangulation triangulate(const camera::RectifiedCamera& grid,
                               const Eigen::Vector3d& right_centre, const Eigen::Vector2d& left_px,
                               double disparity_px) {
  PointTriangulation t;
  if (!left_px.allFinite() || !std::isfinite(disparity_px) || !(disparity_px > 0.0) ||
      !right_centre.allFinite() || !(right_centre.norm() > 0.0)) {
    return t;
  }
  const double right_column = left_px.x() - disparity_px;
  if (!correspondence_angles(grid, left_px, right_column, t)) return t;
  const Eigen::Vector3d u(std::sin(t.alpha_left), std::cos(t.alpha_left) * std::sin(t.beta),
                          std::cos(t.alpha_left) * std::cos(t.beta));
  auto distance_for = [&](double alpha_right) {
    return distance_on_left_ray(u, right_centre, std::sin(alpha_right));
  };
  t.distance_m = distance_for(t.alpha_right);
  if (!std::isfinite(t.distance_m) || !(t.distance_m > 0)) return t;
  t.position_left_rect = t.distance_m * u;
  t.depth_m = t.position_left_rect.z();
  const double lo = distance_for(grid.alpha_of_column(right_column - 0.5));
  const double hi = distance_for(grid.alpha_of_column(right_column + 0.5));
  t.distance_per_px = std::isfinite(lo) && std::isfinite(hi) ? std::abs(hi - lo) : 0.0;
  t.valid = true;
  return t;
}

PointTriangulation triangulate(const RangingGeometry& geometry, const Eigen::Vector2d& left_px,
                               double disparity_px) {
  if (geometry.right_centre_m.isZero()) {
    return triangulate(geometry.grid, geometry.baseline_m, left_px, disparity_px);
  }
  return triangulate(geometry.grid, geometry.right_centre_m, left_px, disparity_px);
}

bool project_point(const camera::RectifiedCamera& grid, double baseline_m, const Eigen::Vector3d& p,
                   Eigen::Vector2d& left_px, double& disparity_px) {
  Eigen::Vector2d right_px;
  if (!(p.z() > 0.0) || !grid.project(p, left_px)) return false;
  if (!grid.project(p - Eigen::Vector3d(baseline_m, 0, 0), right_px)) return false;
  disparity_px = left_px.x() - right_px.x();
  return std::isfinite(disparity_px);
}

double group_window_m(const RangeOptions& options, double distance_m, double m_per_px) {
  return std::max(options.group_relative * distance_m, options.group_disparity_px * m_per_px);
}

bool project_point(const RangingGeometry& geometry, const Eigen::Vector3d& p,
                   Eigen::Vector2d& left_px, double& disparity_px) {
  if (geometry.right_centre_m.isZero())
    return project_point(geometry.grid, geometry.baseline_m, p, left_px, disparity_px);
  Eigen::Vector2d right_px;
  if (!(p.z() > 0.0) || !geometry.grid.project(p, left_px)) return false;
  if (!geometry.grid.project(p - geometry.right_centre_m, right_px)) return false;
  disparity_px = left_px.x() - right_px.x();
  return std::isfinite(disparity_px);
}

std::string status_name(RangeStatus status) {
  return util::name_of(kStatusNames, status, "unknown");
}

namespace {

// Buffers of the Eq. 34 screen, reused: the bootstrap runs it 100 times per target and range.
struct Eq34Scratch {
  std::vector<double> sorted, deviations;
  std::vector<int> kept, next;
};

// Eq. 34 on the kept indices (s.kept, in place): keep mean +- mean absolute deviation
// (max_passes = 1 is the paper's single pass). A pass may leave fewer than 3 points (the target
// is then not ranged): refusing such a pass kept a ground point in front of a 40 m person's 4
// points and ranged it 13.5 m short (thermovis bench ranging, visible and fused at 40 m).
void eq34_passes(const double* values, int max_passes, Eq34Scratch& s) {
  std::vector<int>& kept = s.kept;
  for (int pass = 0; pass < max_passes && kept.size() > 2; ++pass) {
    double mean = 0;
    for (int i : kept) mean += values[i];
    mean /= static_cast<double>(kept.size());
    double mad = 0;
    for (int i : kept) mad += std::abs(values[i] - mean);
    mad /= static_cast<double>(kept.size());
    // Branch-free: which points stay is a coin toss for the branch predictor.
    s.next.resize(kept.size());
    size_t staying = 0;
    for (int i : kept) {
      s.next[staying] = i;
      staying += std::abs(values[i] - mean) <= mad ? 1 : 0;
    }
    s.next.resize(staying);
    if (s.next.size() == kept.size() || s.next.empty()) break;
    kept.swap(s.next);
  }
}

size_t dense_need(size_t count) { return std::max<size_t>(3, (3 * count + 9) / 10); }

// The nearest dense group (reject_outliers_eq34's `windows`): the nearest value with `need`
// values within its window anchors it; its centre is the value of most neighbours within one
// window beyond that anchor (the group's mode, not its near edge); empty when no value has
// `need` neighbours. `sorted`: the values in ascending order, where each value's neighbours
// (|v - values[i]| <= windows[i], monotone in v) are one contiguous run found by bisection.
std::vector<int> nearest_dense_group(const std::vector<double>& values,
                                     const std::vector<double>& windows,
                                     const std::vector<double>& sorted, size_t need, double hint) {
  const auto neighbours = [&](size_t i) {
    const double x = values[i], w = windows[i];
    const auto lo =
        std::partition_point(sorted.begin(), sorted.end(), [&](double v) { return v - x < -w; });
    const auto hi = std::partition_point(lo, sorted.end(), [&](double v) { return v - x <= w; });
    return static_cast<size_t>(hi - lo);
  };
  // The value of most neighbours among those `candidate` accepts (the nearest of equals), and
  // that count; every value is its own neighbour, so a candidate has at least one.
  const auto densest = [&](auto candidate) {
    size_t mode = 0, most = 0;
    for (size_t i = 0; i < values.size(); ++i) {
      if (!candidate(i)) continue;
      const size_t n = neighbours(i);
      if (n > most || (n == most && values[i] < values[mode])) {
        most = n;
        mode = i;
      }
    }
    return std::pair{mode, most};
  };
  std::vector<int> kept;
  size_t mode = 0;
  if (std::isfinite(hint)) {
    size_t most = 0;
    std::tie(mode, most) =
        densest([&](size_t i) { return std::abs(values[i] - hint) <= 2.0 * windows[i]; });
    if (most < 3) return kept;
  } else {
    int anchor = -1;
    for (size_t i = 0; i < values.size(); ++i) {
      if (anchor >= 0 && values[i] >= values[static_cast<size_t>(anchor)]) continue;
      if (neighbours(i) >= need) anchor = static_cast<int>(i);
    }
    if (anchor < 0) return kept;
    const double from = values[static_cast<size_t>(anchor)];
    const double to = from + windows[static_cast<size_t>(anchor)];
    mode = densest([&](size_t i) { return values[i] >= from && values[i] <= to; }).first;
  }
  const double centre = values[mode];
  const double reach = 2.0 * windows[mode];
  for (size_t i = 0; i < values.size(); ++i)
    if (std::abs(values[i] - centre) <= reach) kept.push_back(static_cast<int>(i));
  return kept;
}

// The gap-and-median screen, then Eq. 34, of values[0..count) whose ascending order is in
// s.sorted: the kept indices into s.kept (reject_outliers_eq34 without windows).
void screen_then_eq34(const double* values, size_t count, int max_passes, Eq34Scratch& s) {
  const size_t need = dense_need(count);
  const std::vector<double>& sorted = s.sorted;
  std::vector<int>& kept = s.kept;
  kept.clear();
  for (size_t begin = 0; begin < sorted.size();) {
    size_t end = begin + 1;
    while (end < sorted.size() && sorted[end] <= 1.5 * sorted[end - 1]) ++end;
    if (end - begin >= need && end - begin < sorted.size()) {  // the whole cluster, no more
      const double lo = sorted[begin], hi = sorted[end - 1];
      kept.resize(count);
      size_t inside = 0;
      for (size_t i = 0; i < count; ++i) {
        kept[inside] = static_cast<int>(i);
        inside += values[i] >= lo && values[i] <= hi ? 1 : 0;
      }
      kept.resize(inside);
      break;
    }
    begin = end;
  }
  if (!kept.empty()) return eq34_passes(values, max_passes, s);
  const size_t mid = sorted.size() / 2;
  const double median = sorted[mid];
  s.deviations.resize(sorted.size());
  for (size_t i = 0; i < sorted.size(); ++i) s.deviations[i] = std::abs(sorted[i] - median);
  const auto mid_deviation = s.deviations.begin() + static_cast<std::ptrdiff_t>(mid);
  std::nth_element(s.deviations.begin(), mid_deviation, s.deviations.end());
  const double spread = 5.0 * 1.4826 * *mid_deviation;
  for (size_t i = 0; i < count; ++i) {
    if (std::abs(values[i] - median) <= spread || spread == 0.0)
      kept.push_back(static_cast<int>(i));
  }
  if (spread == 0.0) {  // half or more of the values are identical: keep those
    kept.clear();
    for (size_t i = 0; i < count; ++i)
      if (values[i] == median) kept.push_back(static_cast<int>(i));
  }
  eq34_passes(values, max_passes, s);
}

}  // namespace

std::vector<int> reject_outliers_eq34(const std::vector<double>& values, int max_passes,
                                      const std::vector<double>& windows, double hint) {
  if (values.empty()) return {};
  Eq34Scratch s;
  s.sorted = values;
  std::sort(s.sorted.begin(), s.sorted.end());
  // A target seen before a background that recedes (the ground and walls between and beside
  // the legs) gives distances spread without a gap, so no cluster split below separates them:
  // the target is the nearest group of values as close together as its own depth and noise.
  if (windows.size() == values.size()) {
    s.kept = nearest_dense_group(values, windows, s.sorted, dense_need(values.size()), hint);
    if (s.kept.empty() && std::isfinite(hint)) return {};
    if (!s.kept.empty()) {
      // The group is consistent by construction: Eq. 34 trims it, but a pass that would leave
      // fewer than 3 of its values (one mean absolute deviation of a handful is tight) is not
      // made.
      std::vector<int> group = s.kept;
      eq34_passes(values.data(), max_passes, s);
      return s.kept.size() >= 3 ? s.kept : group;
    }
  }
  // Gross outliers first (far background, a point near infinity): a single far value moves the
  // mean and the mean absolute deviation of Eq. 34 so much that the target's own points could be
  // the ones rejected. Median +- 5 scaled median absolute deviations (about 5 sigma for
  // Gaussian noise) removes only those. But when the sorted distances split into clusters
  // (consecutive values more than 50 % apart), the nearest cluster holding at least 30 % of them
  // is kept instead: a target occludes what lies behind it, so when a box holds as many
  // background points (between the legs, beside the head) as target points, the target is the
  // nearer group, not whichever the median of all falls in.
  screen_then_eq34(values.data(), values.size(), max_passes, s);
  return s.kept;
}

struct Eq34Resampler::Buffers : Eq34Scratch {};

Eq34Resampler::Eq34Resampler(std::vector<double> values, int max_passes)
    : values_(std::move(values)),
      max_passes_(max_passes),
      order_(values_.size()),
      rank_(values_.size()),
      counts_(values_.size(), 0),
      sample_(values_.size()),
      buffers_(std::make_unique<Buffers>()) {
  std::iota(order_.begin(), order_.end(), 0);
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) {
    return values_[static_cast<size_t>(a)] < values_[static_cast<size_t>(b)];
  });
  for (size_t r = 0; r < order_.size(); ++r)
    rank_[static_cast<size_t>(order_[r])] = static_cast<int>(r);
}

Eq34Resampler::~Eq34Resampler() = default;

double Eq34Resampler::estimate(const std::vector<size_t>& picks) {
  const size_t n = picks.size();
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  sample_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    sample_[i] = values_.at(picks[i]);
    ++counts_[static_cast<size_t>(rank_[picks[i]])];
  }
  // The resample in ascending order, by counting its picks' ranks (a counting sort): each
  // rank's first place in the order, then every pick to its rank's next place.
  int place = 0;
  for (int& c : counts_) {
    const int of_rank = c;
    c = place;
    place += of_rank;
  }
  Eq34Scratch& s = *buffers_;
  s.sorted.resize(n);
  for (size_t i = 0; i < n; ++i)
    s.sorted[static_cast<size_t>(counts_[static_cast<size_t>(rank_[picks[i]])]++)] = sample_[i];
  std::fill(counts_.begin(), counts_.end(), 0);
  screen_then_eq34(sample_.data(), n, max_passes_, s);
  double sum = 0;
  for (int i : s.kept) sum += sample_[static_cast<size_t>(i)];
  return sum / static_cast<double>(s.kept.size());
}

TargetShape TargetShape::for_class(const std::string& target_class) {
  TargetShape s;
  if (target_class == "person") {
    // Height 1.75 m: legs to 0.4714, torso to 0.81, neck to 0.874, head (radius 0.07 h) on top.
    s.sections = {{0.0, 0.4714, 0.20, 0.135, false},
                  {0.4714, 0.81, 0.25, 0.15, false},
                  {0.80, 0.874, 0.06, 0.06, false},
                  {0.86, 1.0, 0.1225, 0.1225, true}};
  } else if (target_class == "pole") {
    s.sections = {{0.0, 1.0, 0.10, 0.10, false}};
  } else if (target_class == "marker") {
    s.sections = {{0.0, 1.0, 0.05, 0.05, true}};
  }
  return s;
}

namespace {

// Per-point centre estimates of an upright target (TargetShape): each point's position moved
// along the horizontal line of sight of the box's centre column by the shape's depth in front of
// the axis at the point's height and lateral offset, then up or down the axis to half the box's
// height. Replaces `distances` and `centres` (left rectified frame) in place; `per_px` is scaled
// with the distances.
void move_points_to_centre(const RangingGeometry& g, const cv::Rect& box, const TargetShape& shape,
                           double contour_reach_px, const std::vector<PointTriangulation>& points,
                           std::vector<double>& distances, std::vector<Eigen::Vector3d>& centres,
                           std::vector<double>& per_px) {
  // Vertical (down) in the left rectified frame: the rig frame's +y.
  const Eigen::Vector3d down =
      (g.T_ref_left_rect.linear().transpose() * Eigen::Vector3d::UnitY()).normalized();
  auto ray = [&](double x, double y, Eigen::Vector3d& r) {
    return g.grid.unproject(Eigen::Vector2d(x, y), r);
  };
  const double cx = box.x + 0.5 * box.width - 0.5, cy = box.y + 0.5 * box.height - 0.5;
  Eigen::Vector3d centre_ray, top_ray, bottom_ray, left_ray, right_ray;
  if (!ray(cx, cy, centre_ray) || !ray(cx, box.y - 0.5, top_ray) ||
      !ray(cx, box.br().y - 0.5, bottom_ray) || !ray(box.x - 0.5, cy, left_ray) ||
      !ray(box.br().x - 0.5, cy, right_ray)) {
    return;
  }
  Eigen::Vector3d ahead = centre_ray - centre_ray.dot(down) * down;  // horizontal line of sight
  if (!(ahead.norm() > 1e-9)) return;
  ahead.normalize();
  const Eigen::Vector3d across = down.cross(ahead).normalized();
  // Slopes of the box's border rays: vertical and lateral offsets per metre of depth.
  const auto slope = [&](const Eigen::Vector3d& r, const Eigen::Vector3d& axis) {
    return r.dot(axis) / r.dot(ahead);
  };
  const double top = slope(top_ray, down), bottom = slope(bottom_ray, down);
  const double half_width_slope =
      0.5 * std::abs(slope(right_ray, across) - slope(left_ray, across));
  if (!(bottom > top) || !(centre_ray.dot(ahead) > 0)) return;
  std::vector<double> depths;
  for (const PointTriangulation& p : points) depths.push_back(p.position_left_rect.dot(ahead));
  std::vector<double> sorted(depths);
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2),
                   sorted.end());
  const double z0 = sorted[sorted.size() / 2];
  if (!(z0 > 0)) return;
  // Lateral scale: the box's measured half-width against the shape's widest section (the
  // target's heading and build), within +-30 %.
  double widest = 0;
  for (const auto& s : shape.sections) widest = std::max(widest, s.half_width_m);
  const double scale = std::clamp(half_width_slope * z0 / widest, 0.7, 1.3);
  const double height_m = (bottom - top) * z0;
  const double reach_m = std::max(0.0, contour_reach_px) * z0 / g.grid.intrinsics().f;
  const double mid = 0.5 * (top + bottom);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d& P = points[i].position_left_rect;
    const double x = P.dot(across), f = (bottom * z0 - P.dot(down)) / height_m;
    double offset = 0, width = -1;
    for (const auto& s : shape.sections) {
      if (f < s.from || f > s.to) continue;
      double a = s.half_width_m * scale, b = s.half_depth_m;
      if (s.sphere) {  // the sphere's circle at this height
        const double dz = (f - 0.5 * (s.from + s.to)) * height_m;
        const double r2 = s.half_width_m * s.half_width_m - dz * dz;
        if (r2 <= 0) continue;
        a = std::sqrt(r2) * scale;
        b = std::sqrt(r2);
      }
      if (a <= width) continue;  // the outermost section at this height
      width = a;
      // The depth of the outermost surface the point's patch covers: where the occluding
      // contour falls inside the patch, the contour (the strongest edge, at the axis depth in
      // both eyes) is what the correlation aligns, not the surface at the patch's centre.
      const double xe = std::abs(x) + reach_m;
      offset = xe < a ? b * std::sqrt(1.0 - (xe / a) * (xe / a)) : 0.0;
    }
    const double axis_depth = depths[i] + offset;
    centres[i] = axis_depth * (ahead + mid * down);
    const double d = centres[i].norm();
    per_px[i] *= d / distances[i];
    distances[i] = d;
  }
}

double mean_of(const std::vector<double>& values, const std::vector<int>& indices) {
  double sum = 0;
  for (int i : indices) sum += values[static_cast<size_t>(i)];
  return sum / static_cast<double>(indices.size());
}

TargetRange fail(TargetRange r, RangeStatus status, std::string message) {
  r.status = status;
  r.message = std::move(message);
  return r;
}

}  // namespace

TargetRange range_target(const RangingGeometry& geometry, const cv::Rect& box,
                         const std::vector<match::Correspondence>& matches,
                         const RangeOptions& options) {
  TargetRange r;
  r.points_total = static_cast<int>(matches.size());
  const cv::Size size = geometry.grid.image_size();
  const cv::Rect image(0, 0, size.width, size.height);
  std::ostringstream where;
  where << "box (x " << box.x << ", y " << box.y << ", " << box.width << " x " << box.height << ")";
  if (box.width <= 0 || box.height <= 0) {
    return fail(r, RangeStatus::empty_box, where.str() + " has no area");
  }
  const cv::Rect inside = box & image;
  if (inside.empty()) {
    return fail(r, RangeStatus::box_outside_image,
                where.str() + " is outside the " + std::to_string(size.width) + " x " +
                    std::to_string(size.height) + " image");
  }
  const int m = options.edge_margin_px;
  r.at_image_edge = inside != box || box.x < m || box.y < m || box.br().x > size.width - m ||
                    box.br().y > size.height - m;
  if (!(geometry.baseline_m > 0.0)) {
    throw std::invalid_argument("range_target: baseline must be positive");
  }

  // Per-point triangulation of the matches whose left pixel lies in the box.
  std::vector<PointTriangulation> points;
  std::vector<double> distances, disparities;
  std::vector<int> source;  // index of each valid point in `matches`
  int in_box = 0;
  for (size_t k = 0; k < matches.size(); ++k) {
    const match::Correspondence& c = matches[k];
    if (!(c.left.x() >= inside.x - 0.5 && c.left.x() < inside.br().x - 0.5 &&
          c.left.y() >= inside.y - 0.5 && c.left.y() < inside.br().y - 0.5)) {
      continue;
    }
    ++in_box;
    const PointTriangulation t = triangulate(geometry, c.left, c.disparity_px);
    if (!t.valid) continue;
    points.push_back(t);
    source.push_back(static_cast<int>(k));
    distances.push_back(t.distance_m);
    disparities.push_back(c.disparity_px);
  }
  r.points_valid = static_cast<int>(points.size());
  std::vector<Eigen::Vector3d> centres;
  std::vector<double> per_px;
  for (const PointTriangulation& t : points) {
    centres.push_back(t.position_left_rect);
    per_px.push_back(t.distance_per_px);
  }
  if (!options.shape.empty() && !points.empty()) {
    move_points_to_centre(geometry, inside, options.shape, options.contour_reach_px, points,
                          distances, centres, per_px);
  }
  if (points.empty()) {
    if (r.at_image_edge) {
      return fail(r, RangeStatus::target_at_image_edge,
                  where.str() + " touches the image edge and has no valid correspondence: the " +
                      "other eye or the correlation patch does not see the target there");
    }
    return fail(r, in_box == 0 ? RangeStatus::no_matches : RangeStatus::too_few_points,
                in_box == 0 ? where.str() + ": no correspondence in the box"
                            : where.str() + ": no correspondence with a positive disparity");
  }
  std::vector<double> windows;
  if (options.group_relative > 0 || options.group_disparity_px > 0) {
    for (size_t i = 0; i < distances.size(); ++i) {
      windows.push_back(group_window_m(options, distances[i], per_px[i]));
    }
  }
  const double hint = windows.empty() ? TargetRange::nan : options.group_hint_m;
  const std::vector<int> kept =
      reject_outliers_eq34(distances, options.max_rejection_passes, windows, hint);
  r.points_used = static_cast<int>(kept.size());
  if (r.points_used < std::max(1, options.min_points)) {
    std::ostringstream near_hint;
    if (std::isfinite(hint))
      near_hint << std::fixed << std::setprecision(2) << " within two windows of " << hint << " m";
    return fail(r,
                r.at_image_edge ? RangeStatus::target_at_image_edge : RangeStatus::too_few_points,
                where.str() + ": " + std::to_string(r.points_used) + " point(s) kept by Eq. 34" +
                    near_hint.str() + ", " + std::to_string(options.min_points) + " needed" +
                    (r.at_image_edge ? " (the box touches the image edge)" : ""));
  }
  for (int i : kept) r.used.push_back(source[static_cast<size_t>(i)]);
  r.distance_m = mean_of(distances, kept);
  r.disparity_px = mean_of(disparities, kept);
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double depth = 0, distance_per_px = 0;
  for (int i : kept) {
    position += centres[static_cast<size_t>(i)];
    depth += centres[static_cast<size_t>(i)].z();
    distance_per_px += per_px[static_cast<size_t>(i)];
  }
  const double n = static_cast<double>(kept.size());
  r.depth_m = depth / n;
  distance_per_px /= n;
  // Scale the mean position onto the mean distance (the mean of points on a sphere lies inside it).
  position /= n;
  if (position.norm() > 0) position *= r.distance_m / position.norm();
  r.position_m = geometry.T_ref_left_rect * position;

  // Random part: bootstrap of the Eq. 34 estimator over the points that pass the gross screen
  // (the target's own points; fixed seed: the same input gives the same uncertainty). Resampling
  // the background points too would let a resample with half of them move the median onto the
  // background: a few such resamples made sigma metres for a target ranged to centimetres.
  double random_sigma = 0;
  std::vector<double> screened;
  for (int i : reject_outliers_eq34(distances, 0, windows, hint))
    screened.push_back(distances[static_cast<size_t>(i)]);
  if (screened.size() >= 2 && options.bootstrap_samples > 1) {
    std::mt19937 rng(static_cast<unsigned>(screened.size()) * 2654435761u);
    std::uniform_int_distribution<size_t> pick(0, screened.size() - 1);
    std::vector<size_t> picks(screened.size());
    const size_t count = screened.size();
    Eq34Resampler resampler(std::move(screened), options.max_rejection_passes);
    double sum = 0, sum2 = 0;
    for (int b = 0; b < options.bootstrap_samples; ++b) {
      for (size_t& p : picks) p = pick(rng);
      const double estimate = resampler.estimate(picks);
      sum += estimate;
      sum2 += estimate * estimate;
    }
    const double B = options.bootstrap_samples;
    random_sigma = std::sqrt(std::max(0.0, (sum2 - sum * sum / B) / (B - 1)));
    // Small samples: the bootstrap spread is biased low by sqrt((n-1)/n), and a one-sigma
    // interval needs Student's t_{0.84}(n-1) ~ 1 + 0.57/(n-1) to hold 68 %.
    const double nv = static_cast<double>(count);
    random_sigma *= std::sqrt(nv / (nv - 1)) * (1.0 + 0.57 / (nv - 1));
  }
  const double systematic_sigma = distance_per_px * options.systematic_disparity_px;
  const double shape_sigma = options.shape.empty() ? 0.0 : options.shape_sigma_m;
  r.sigma_m = std::sqrt(random_sigma * random_sigma + systematic_sigma * systematic_sigma +
                        shape_sigma * shape_sigma);
  r.disparity_sigma_px = distance_per_px > 0 ? r.sigma_m / distance_per_px : TargetRange::nan;
  r.status = RangeStatus::ok;
  return r;
}

TargetRange range_region(const RangingGeometry& geometry, const cv::Rect& box,
                         const match::RegionDisparity& region, double surface_to_centre_m,
                         const RangeOptions& options) {
  TargetRange r;
  const cv::Size size = geometry.grid.image_size();
  const int m = options.edge_margin_px;
  r.at_image_edge =
      box.x < m || box.y < m || box.br().x > size.width - m || box.br().y > size.height - m;
  if (!region.ok()) {
    return fail(
        r, RangeStatus::no_region,
        "whole-region alignment: " +
            (region.message.empty() ? match::region_status_name(region.status) : region.message));
  }
  const PointTriangulation t = triangulate(geometry, region.anchor, region.disparity_px);
  if (!t.valid) {
    return fail(r, RangeStatus::no_region,
                "whole-region alignment: disparity " + std::to_string(region.disparity_px) +
                    " px at the anchor does not triangulate");
  }
  r.region_pixels = region.pixels;
  const double inside_share = std::isfinite(region.contour_fraction)
                                  ? std::clamp(1.0 - region.contour_fraction, 0.0, 1.0)
                                  : 0.5;
  const double offset = surface_to_centre_m * inside_share;
  Eigen::Vector3d position = t.position_left_rect;
  position *= (t.distance_m + offset) / t.distance_m;
  r.distance_m = position.norm();
  r.depth_m = position.z();
  r.disparity_px = region.disparity_px;
  r.position_m = geometry.T_ref_left_rect * position;
  const double px2 = region.sigma_px * region.sigma_px + options.region_systematic_disparity_px *
                                                             options.region_systematic_disparity_px;
  r.sigma_m = std::sqrt(px2 * t.distance_per_px * t.distance_per_px +
                        options.region_model_sigma_m * options.region_model_sigma_m);
  r.disparity_sigma_px = t.distance_per_px > 0 ? r.sigma_m / t.distance_per_px : TargetRange::nan;
  r.status = RangeStatus::ok;
  return r;
}

double surface_to_centre_m(const std::string& target_class) {
  if (target_class == "person") return 0.15 * M_PI / 4;
  if (target_class == "pole") return 0.10 * M_PI / 4;
  if (target_class == "marker") return 0.05 * 2.0 / 3.0;
  return 0.0;
}

double max_disparity_for(const RangingGeometry& geometry, double min_distance_m) {
  return geometry.grid.intrinsics().f * geometry.baseline_m / std::max(0.1, min_distance_m) + 2.0;
}

void move_to_centre(TargetRange& range, const RangingGeometry& geometry, double offset_m) {
  if (range.status != RangeStatus::ok || offset_m == 0.0) return;
  const double scale = (range.distance_m + offset_m) / range.distance_m;
  const Eigen::Vector3d origin = geometry.T_ref_left_rect.translation();
  range.position_m = origin + (range.position_m - origin) * scale;
  range.depth_m *= scale;
  range.distance_m += offset_m;
}

TargetRange combine_ranges(const TargetRange& a, const TargetRange& b,
                           const RangingGeometry& report, double shared_sigma_m,
                           CombinedFrom* from) {
  const bool a_ok = a.status == RangeStatus::ok && std::isfinite(a.sigma_m) && a.sigma_m > 0;
  const bool b_ok = b.status == RangeStatus::ok && std::isfinite(b.sigma_m) && b.sigma_m > 0;
  if (from != nullptr) {
    *from = a_ok ? (b_ok ? CombinedFrom::both : CombinedFrom::a)
                 : (b_ok ? CombinedFrom::b : CombinedFrom::neither);
  }
  if (!a_ok && !b_ok) {
    TargetRange r = a;
    if (a.status == RangeStatus::ok || b.status == RangeStatus::ok) {
      r.status = RangeStatus::too_few_points;
      r.message = "no range with a finite uncertainty to combine";
    } else {
      r.message = a.message + "; " + b.message;
    }
    r.used.clear();
    return r;
  }
  TargetRange r = a_ok ? a : b;
  if (a_ok && b_ok) {
    // Inverse-variance weights on each measurement's own part; the shared part stays whole.
    const double shared2 = shared_sigma_m * shared_sigma_m;
    const double va = std::max(a.sigma_m * a.sigma_m - shared2, 1e-12);
    const double vb = std::max(b.sigma_m * b.sigma_m - shared2, 1e-12);
    const double wa = 1.0 / va, wb = 1.0 / vb;
    r.position_m = (wa * a.position_m + wb * b.position_m) / (wa + wb);
    r.sigma_m = std::sqrt(1.0 / (wa + wb) + shared2);
    r.points_total = a.points_total + b.points_total;
    r.points_valid = a.points_valid + b.points_valid;
    r.points_used = a.points_used + b.points_used;
    r.region_pixels = a.region_pixels + b.region_pixels;
    r.at_image_edge = a.at_image_edge && b.at_image_edge;
  }
  r.used.clear();
  // Distance, depth and disparity as seen from the report geometry's left camera.
  const Eigen::Vector3d local = report.T_ref_left_rect.inverse() * r.position_m;
  r.distance_m = local.norm();
  r.depth_m = local.z();
  Eigen::Vector2d px;
  double disparity = 0;
  if (project_point(report, local, px, disparity)) {
    const PointTriangulation t = triangulate(report, px, disparity);
    r.disparity_px = disparity;
    r.disparity_sigma_px =
        t.valid && t.distance_per_px > 0 ? r.sigma_m / t.distance_per_px : TargetRange::nan;
  } else {
    r.disparity_px = r.disparity_sigma_px = TargetRange::nan;
  }
  return r;
}

}  // namespace thermovis::range
