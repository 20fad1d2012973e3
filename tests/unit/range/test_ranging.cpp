// Triangulation over the whole wide field, Eq. 34 rejection, the honesty of the uncertainty
// (about 68 % of errors within one sigma) and the statuses of bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "thermovis/range/ranging.hpp"

namespace rg = thermovis::range;
namespace cam = thermovis::camera;

namespace {

// The paper rig's visible grid (rectify::default_pair_grid): 1864 x 1082, 835.4 px per rad.
cam::RectifiedCamera visible_grid(
    cam::RectifiedProjection projection = cam::RectifiedProjection::equirectangular) {
  cam::RectifiedIntrinsics g;
  g.width = 1864;
  g.height = 1082;
  g.f = 835.4;
  g.cx = (g.width - 1) / 2.0;
  g.cy = (g.height - 1) / 2.0;
  g.projection = projection;
  return cam::RectifiedCamera(g);
}

constexpr double kBaseline = 0.335;

// A target at `distance` along bearing (azimuth, elevation) in rad, in the left rectified frame.
Eigen::Vector3d at_bearing(double distance, double azimuth, double elevation) {
  return distance * Eigen::Vector3d(std::sin(azimuth), std::cos(azimuth) * std::sin(elevation),
                                    std::cos(azimuth) * std::cos(elevation));
}

}  // namespace

TEST(Triangulate, ExactOverTheWideFieldBothProjections) {
  for (auto projection :
       {cam::RectifiedProjection::equirectangular, cam::RectifiedProjection::cylindrical}) {
    const cam::RectifiedCamera grid = visible_grid(projection);
    for (double distance : {2.0, 5.0, 20.0, 60.0, 200.0})
      for (double az_deg : {-58.0, -30.0, 0.0, 25.0, 58.0})
        for (double el_deg : {-30.0, 0.0, 20.0}) {
          const Eigen::Vector3d p = at_bearing(distance, az_deg * M_PI / 180, el_deg * M_PI / 180);
          Eigen::Vector2d px;
          double d = 0;
          ASSERT_TRUE(rg::project_point(grid, kBaseline, p, px, d));
          const rg::PointTriangulation t = rg::triangulate(grid, kBaseline, px, d);
          ASSERT_TRUE(t.valid);
          EXPECT_NEAR(t.distance_m, p.norm(), 1e-9 * distance);
          EXPECT_NEAR((t.position_left_rect - p).norm(), 0.0, 1e-9 * distance);
          EXPECT_NEAR(t.depth_m, p.z(), 1e-9 * distance);  // Eq. 33
        }
  }
}

// A pair shown on another pair's grid: the right eye off the grid's x axis (the paper rig's
// infrared pair on the visible grid: its right eye is 68 mm off the axis). Triangulating from
// the true right centre is exact; taking only its x component (the rectified formula) is off by
// centimetres at 5 m and metres at 60 m, with a sign that follows the bearing.
TEST(Triangulate, ExactWhenTheRightEyeIsOffTheGridsAxis) {
  const Eigen::Vector3d right(0.352, 0.011, 0.051);
  for (auto projection :
       {cam::RectifiedProjection::equirectangular, cam::RectifiedProjection::cylindrical}) {
    const cam::RectifiedCamera grid = visible_grid(projection);
    double worst_rectified = 0;
    for (double distance : {2.0, 5.0, 20.0, 60.0})
      for (double az_deg : {-50.0, -20.0, 0.0, 25.0, 50.0})
        for (double el_deg : {-20.0, 0.0, 15.0}) {
          const Eigen::Vector3d p = at_bearing(distance, az_deg * M_PI / 180, el_deg * M_PI / 180);
          Eigen::Vector2d left_px, right_px;
          ASSERT_TRUE(grid.project(p, left_px));
          ASSERT_TRUE(grid.project(p - right, right_px));
          const double d = left_px.x() - right_px.x();
          const rg::PointTriangulation t = rg::triangulate(grid, right, left_px, d);
          ASSERT_TRUE(t.valid) << distance << " m at " << az_deg << " deg";
          EXPECT_NEAR((t.position_left_rect - p).norm(), 0.0, 1e-8 * distance);
          EXPECT_NEAR(t.depth_m, p.z(), 1e-8 * distance);
          EXPECT_GT(t.distance_per_px, 0.0);
          const rg::PointTriangulation on_axis = rg::triangulate(grid, right.x(), left_px, d);
          if (on_axis.valid) {
            worst_rectified =
                std::max(worst_rectified, std::abs(on_axis.distance_m - p.norm()) / p.norm());
          }
        }
    EXPECT_GT(worst_rectified, 0.02) << "the off-axis eye should matter";
  }
  // On the axis, the same as the rectified formula, sensitivity included.
  const cam::RectifiedCamera grid = visible_grid();
  const Eigen::Vector3d p = at_bearing(15.0, 0.4, 0.1);
  Eigen::Vector2d px;
  double d = 0;
  ASSERT_TRUE(rg::project_point(grid, kBaseline, p, px, d));
  const rg::PointTriangulation a = rg::triangulate(grid, kBaseline, px, d);
  const rg::PointTriangulation b = rg::triangulate(grid, Eigen::Vector3d(kBaseline, 0, 0), px, d);
  ASSERT_TRUE(a.valid && b.valid);
  EXPECT_NEAR(a.distance_m, b.distance_m, 1e-9);
  EXPECT_NEAR(a.distance_per_px, b.distance_per_px, 1e-3 * a.distance_per_px);
  // The geometry picks the formula.
  rg::RangingGeometry g{grid, kBaseline, Eigen::Isometry3d::Identity()};
  EXPECT_NEAR(rg::triangulate(g, px, d).distance_m, a.distance_m, 1e-12);
  g.right_centre_m = right;
  EXPECT_NEAR(rg::triangulate(g, px, d).distance_m, rg::triangulate(grid, right, px, d).distance_m,
              1e-12);
  // And projects back where that triangulation ranges (the on-axis projection does not).
  Eigen::Vector2d off_px;
  double off_d = 0;
  ASSERT_TRUE(rg::project_point(g, p, off_px, off_d));
  EXPECT_NEAR((off_px - px).norm(), 0.0, 1e-9);
  EXPECT_NEAR(rg::triangulate(g, off_px, off_d).distance_m, p.norm(), 1e-8 * p.norm());
  EXPECT_GT(std::abs(off_d - d), 0.05);
  // Nothing in front: no point.
  EXPECT_FALSE(rg::triangulate(grid, right, px, -1.0).valid);
  EXPECT_FALSE(rg::triangulate(grid, Eigen::Vector3d::Zero(), px, d).valid);
}

TEST(Triangulate, SensitivityMatchesEq2AtTheCentreAndNumericEverywhere) {
  const cam::RectifiedCamera grid = visible_grid();
  // Eq. 2 at the centre: dL = L^2 dc / (f A).
  for (double L : {5.0, 20.0, 60.0}) {
    Eigen::Vector2d px;
    double d = 0;
    ASSERT_TRUE(rg::project_point(grid, kBaseline, at_bearing(L, 0.0, 0.0), px, d));
    const auto t = rg::triangulate(grid, kBaseline, px, d);
    EXPECT_NEAR(t.distance_per_px, L * L / (835.4 * kBaseline), 0.01 * L * L / (835.4 * kBaseline));
  }
  // Off axis: against a finite difference.
  Eigen::Vector2d px;
  double d = 0;
  ASSERT_TRUE(rg::project_point(grid, kBaseline, at_bearing(30, 0.9, 0.2), px, d));
  const auto t = rg::triangulate(grid, kBaseline, px, d);
  const double numeric = (rg::triangulate(grid, kBaseline, px, d - 1e-4).distance_m -
                          rg::triangulate(grid, kBaseline, px, d + 1e-4).distance_m) /
                         2e-4;
  EXPECT_NEAR(t.distance_per_px, numeric, 1e-4 * numeric);
}

TEST(Triangulate, NonPositiveOrBrokenDisparityIsInvalid) {
  const cam::RectifiedCamera grid = visible_grid();
  EXPECT_FALSE(rg::triangulate(grid, kBaseline, {900, 500}, 0.0).valid);
  EXPECT_FALSE(rg::triangulate(grid, kBaseline, {900, 500}, -3.0).valid);
  EXPECT_FALSE(rg::triangulate(grid, kBaseline, {900, 500}, std::nan("")).valid);
  EXPECT_FALSE(rg::triangulate(grid, kBaseline, {std::nan(""), 500}, 5.0).valid);
  EXPECT_FALSE(rg::triangulate(grid, 0.0, {900, 500}, 5.0).valid);
}

TEST(Eq34, RejectsBackgroundAndFarPoints) {
  std::vector<double> v;
  for (int i = 0; i < 70; ++i) v.push_back(20.0 + 0.01 * (i % 7 - 3));
  for (int i = 0; i < 30; ++i) v.push_back(60.0);
  v.push_back(3000.0);
  const auto kept = rg::reject_outliers_eq34(v, 1);
  ASSERT_FALSE(kept.empty());
  for (int i : kept) EXPECT_LT(v[static_cast<size_t>(i)], 21.0);
}

// A person at 5 m before ground and walls that recede without a gap (the distances of a box's
// points between and beside the legs): no split of 50 % separates them, the nearest dense group
// does.
TEST(Eq34, KeepsTheNearestDenseGroupBeforeABackgroundThatRecedes) {
  const std::vector<double> v = {5.02, 4.99, 5.05, 5.01, 5.08, 4.97, 5.04, 5.06, 5.00, 6.3,
                                 6.4,  8.8,  9.0,  12.9, 13.2, 13.3, 14.3, 20.0, 29.0, 113.0};
  std::vector<double> windows;
  for (double d : v) windows.push_back(0.06 * d);
  const auto grouped = rg::reject_outliers_eq34(v, 1, windows);
  ASSERT_GE(grouped.size(), 3u);
  for (int i : grouped) EXPECT_LT(v[static_cast<size_t>(i)], 5.1);
  // Without the windows the background takes part.
  bool background = false;
  for (int i : rg::reject_outliers_eq34(v, 1)) background |= v[static_cast<size_t>(i)] > 6.0;
  EXPECT_TRUE(background);
}

TEST(Eq34, AGroupOfAFewIsNotTrimmedBelowThree) {
  // Five consistent values: one mean absolute deviation around their mean holds two.
  const std::vector<double> v = {5.00, 5.01, 5.03, 5.06, 5.07, 9.0, 12.0, 15.0};
  const std::vector<double> windows(v.size(), 0.3);
  const auto kept = rg::reject_outliers_eq34(v, 1, windows);
  EXPECT_EQ(kept.size(), 5u);
  for (int i : kept) EXPECT_LT(v[static_cast<size_t>(i)], 5.1);
}

// A small box's points: seven on the person at 25 m, three matched one period of a repeated
// texture off and so ranged at 16.6 m, a nearer group of 30 % that the nearest-group screen
// keeps. The region's range (a hint near 25 m) keeps the person's group; a hint where no group
// of three lies keeps nothing.
TEST(Eq34, AHintKeepsTheGroupNearItNotANearerOne) {
  const std::vector<double> v = {25.02, 24.91, 25.10, 16.61, 24.95,
                                 16.65, 25.05, 16.58, 24.98, 25.07};
  std::vector<double> windows;
  for (double d : v) windows.push_back(0.06 * d);
  for (int i : rg::reject_outliers_eq34(v, 1, windows)) EXPECT_LT(v[static_cast<size_t>(i)], 17.0);
  const auto near_hint = rg::reject_outliers_eq34(v, 1, windows, 25.3);
  ASSERT_GE(near_hint.size(), 3u);
  for (int i : near_hint) EXPECT_GT(v[static_cast<size_t>(i)], 24.0);
  EXPECT_TRUE(rg::reject_outliers_eq34(v, 1, windows, 40.0).empty());
}

// The bootstrap's resampler gives what Eq. 34 gives on each resample, to the bit: sets with a
// near cluster and a far one, gross outliers, ties (the median path with no spread) and single
// values, resampled with replacement.
TEST(Eq34, TheResamplerEqualsEq34OnEachResample) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int set = 0; set < 60; ++set) {
    const size_t n = 2 + static_cast<size_t>(set % 20) * 7;
    std::vector<double> values;
    for (size_t i = 0; i < n; ++i) {
      const int kind = static_cast<int>(i % 5);
      double v = 20.0 + 0.2 * noise(rng);
      if (set % 3 == 1 && kind == 4) v = 45.0 + noise(rng);  // a farther cluster
      if (set % 3 == 2 && kind >= 3) v = 7.5;                // ties
      if (i == 1 && set % 4 == 0) v = 3000.0;                // far outlier
      values.push_back(v);
    }
    for (int passes : {0, 1, 3}) {
      rg::Eq34Resampler resampler(values, passes);
      std::uniform_int_distribution<size_t> pick(0, n - 1);
      std::vector<size_t> picks(n);
      std::vector<double> sample(n);
      for (int b = 0; b < 20; ++b) {
        for (size_t i = 0; i < n; ++i) sample[i] = values[picks[i] = pick(rng)];
        const std::vector<int> kept = rg::reject_outliers_eq34(sample, passes);
        double sum = 0;
        for (int i : kept) sum += sample[static_cast<size_t>(i)];
        ASSERT_EQ(resampler.estimate(picks), sum / static_cast<double>(kept.size()))
            << "set " << set << ", " << passes << " passes, resample " << b;
      }
    }
  }
  rg::Eq34Resampler resampler({1.0, 2.0}, 1);
  EXPECT_TRUE(std::isnan(resampler.estimate({})));
  EXPECT_THROW(resampler.estimate({0, 2}), std::out_of_range);
}

namespace {

struct Trial {
  double error_m, sigma_m;
  bool ranged;  // false: too few consistent points (said so, no distance)
};

// A target of n points at distance L and random bearing, disparities with Gaussian noise of
// sigma_px, and a fraction of background points (at 3 L); the truth is the distance of the
// target's points (all at the same distance).
Trial noisy_trial(std::mt19937& rng, const cam::RectifiedCamera& grid, double L, int n,
                  double sigma_px, double background_fraction, const rg::RangeOptions& options) {
  std::uniform_real_distribution<double> az(-0.9, 0.9), el(-0.3, 0.3), jitter(-0.01, 0.01), u(0, 1);
  std::normal_distribution<double> noise(0.0, sigma_px);
  const double a0 = az(rng), e0 = el(rng);
  std::vector<thermovis::match::Correspondence> matches;
  for (int i = 0; i < n; ++i) {
    const bool background = u(rng) < background_fraction;
    const Eigen::Vector3d p =
        at_bearing(background ? 3 * L : L, a0 + jitter(rng), e0 + jitter(rng));
    Eigen::Vector2d px;
    double d = 0;
    if (!rg::project_point(grid, kBaseline, p, px, d)) continue;
    // Pixel-centre left point (like the matcher's snapped pixels), disparity of that pixel.
    thermovis::match::Correspondence c{};
    c.left = px;
    c.disparity_px = d + noise(rng);
    matches.push_back(c);
  }
  rg::RangingGeometry geometry{grid, kBaseline, Eigen::Isometry3d::Identity()};
  const rg::TargetRange r =
      rg::range_target(geometry, cv::Rect(0, 0, 1864, 1082), matches, options);
  // Too few points kept (reported as at the image edge: the box is the whole image).
  if ((r.status == rg::RangeStatus::too_few_points ||
       r.status == rg::RangeStatus::target_at_image_edge) &&
      r.points_used < std::max(1, options.min_points))
    return {0.0, 0.0, false};
  EXPECT_EQ(r.status, rg::RangeStatus::ok) << r.message;
  return {r.distance_m - L, r.sigma_m, true};
}

}  // namespace

TEST(RangeTarget, UncertaintyIsHonestOverManyTrials) {
  const cam::RectifiedCamera grid = visible_grid();
  rg::RangeOptions options;
  options.systematic_disparity_px = 0.0;  // the synthetic noise is purely random
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> distance(5, 60), noise(0.05, 0.3), bg(0.0, 0.3);
  std::uniform_int_distribution<int> count(8, 200);
  int within = 0, ranged = 0;
  const int trials = 1500;
  for (int k = 0; k < trials; ++k) {
    const Trial t = noisy_trial(rng, grid, distance(rng), count(rng), noise(rng), bg(rng), options);
    if (!t.ranged) continue;
    ++ranged;
    within += std::abs(t.error_m) <= t.sigma_m;
  }
  // A target whose few points Eq. 34 leaves fewer than 3 of is not ranged (8-point targets with
  // background points): rarely.
  EXPECT_GE(ranged, trials * 99 / 100);
  const double fraction = double(within) / ranged;
  std::cout << "within one sigma: " << 100 * fraction << " % of " << ranged << " ranged\n";
  EXPECT_GT(fraction, 0.62);
  EXPECT_LT(fraction, 0.75);
}

TEST(RangeTarget, AccurateWithManyPoints) {
  const cam::RectifiedCamera grid = visible_grid();
  std::mt19937 rng(3);
  const Trial t = noisy_trial(rng, grid, 20.0, 300, 0.05, 0.2, {});
  EXPECT_LT(std::abs(t.error_m), 0.1);
  EXPECT_LT(std::abs(t.error_m), 3 * t.sigma_m);
}

TEST(RangeTarget, BadInputSaysWhy) {
  const cam::RectifiedCamera grid = visible_grid();
  const rg::RangingGeometry geometry{grid, kBaseline, Eigen::Isometry3d::Identity()};
  std::vector<thermovis::match::Correspondence> matches;
  thermovis::match::Correspondence c{};
  c.left = {500, 500};
  c.disparity_px = 10;
  for (int i = 0; i < 5; ++i) matches.push_back(c);

  auto r = rg::range_target(geometry, cv::Rect(480, 480, 0, 40), matches);
  EXPECT_EQ(r.status, rg::RangeStatus::empty_box);
  EXPECT_TRUE(std::isnan(r.distance_m));
  EXPECT_FALSE(r.message.empty());
  r = rg::range_target(geometry, cv::Rect(5000, 480, 40, 40), matches);
  EXPECT_EQ(r.status, rg::RangeStatus::box_outside_image);
  r = rg::range_target(geometry, cv::Rect(480, 480, 40, 40), {});
  EXPECT_EQ(r.status, rg::RangeStatus::no_matches);
  EXPECT_TRUE(std::isnan(r.sigma_m));
  r = rg::range_target(geometry, cv::Rect(0, 480, 40, 40), {});
  EXPECT_EQ(r.status, rg::RangeStatus::target_at_image_edge);
  // Matches outside the box are not used.
  r = rg::range_target(geometry, cv::Rect(100, 100, 40, 40), matches);
  EXPECT_EQ(r.status, rg::RangeStatus::no_matches);
  // Only non-positive disparities: no distance.
  auto zero = matches;
  for (auto& z : zero) z.disparity_px = 0.0;
  r = rg::range_target(geometry, cv::Rect(480, 480, 40, 40), zero);
  EXPECT_EQ(r.status, rg::RangeStatus::too_few_points);
  EXPECT_TRUE(std::isnan(r.distance_m));
  // NaN disparities are dropped, not propagated.
  auto broken = matches;
  broken[0].disparity_px = std::nan("");
  r = rg::range_target(geometry, cv::Rect(480, 480, 40, 40), broken);
  EXPECT_EQ(r.status, rg::RangeStatus::ok);
  EXPECT_TRUE(std::isfinite(r.distance_m));
  EXPECT_EQ(r.points_valid, 4);
  // Good input: the distance of disparity 10 px at that column.
  EXPECT_NEAR(r.distance_m, rg::triangulate(grid, kBaseline, {500, 500}, 10).distance_m, 1e-9);
}

// Two pairs' ranges of one target: inverse-variance weights on their own errors, the shared
// (shape) error kept whole; one failed range gives the other; both failed say why; `from` says
// which were used.
TEST(CombineRanges, WeighsEachPairByItsOwnUncertainty) {
  const cam::RectifiedCamera grid = visible_grid();
  const rg::RangingGeometry report{grid, kBaseline, Eigen::Isometry3d::Identity()};
  rg::TargetRange a, b;
  a.status = b.status = rg::RangeStatus::ok;
  a.position_m = {0.0, 0.0, 20.0};
  a.sigma_m = 0.1;
  a.points_used = 7;
  b.position_m = {0.0, 0.0, 21.0};
  b.sigma_m = 0.2;
  b.points_used = 5;
  rg::CombinedFrom from = rg::CombinedFrom::neither;
  rg::TargetRange c = rg::combine_ranges(a, b, report, 0.0, &from);
  ASSERT_EQ(c.status, rg::RangeStatus::ok);
  EXPECT_EQ(from, rg::CombinedFrom::both);
  // Weights 100 : 25.
  EXPECT_NEAR(c.distance_m, 20.2, 1e-9);
  EXPECT_NEAR(c.depth_m, 20.2, 1e-9);
  EXPECT_NEAR(c.sigma_m, std::sqrt(1.0 / 125.0), 1e-12);
  EXPECT_EQ(c.points_used, 12);
  EXPECT_TRUE(c.used.empty());
  EXPECT_GT(c.disparity_px, 0.0);
  EXPECT_GT(c.disparity_sigma_px, 0.0);

  // A shared 0.08 m: own parts 0.06 and 0.183 m, weights 277.8 : 29.9; the shared part whole.
  c = rg::combine_ranges(a, b, report, 0.08);
  const double wa = 1 / (0.01 - 0.0064), wb = 1 / (0.04 - 0.0064);
  EXPECT_NEAR(c.distance_m, (wa * 20 + wb * 21) / (wa + wb), 1e-9);
  EXPECT_NEAR(c.sigma_m, std::sqrt(1 / (wa + wb) + 0.0064), 1e-12);
  EXPECT_GT(c.sigma_m, 0.08);

  // One failed: the other, from the report camera (here 1 m to the side of b's frame).
  rg::TargetRange failed;
  failed.status = rg::RangeStatus::too_few_points;
  failed.message = "box (x 1, y 1, 8 x 20): 1 point(s) kept by Eq. 34, 3 needed";
  const rg::RangingGeometry shifted{grid, kBaseline,
                                    Eigen::Isometry3d(Eigen::Translation3d(1.0, 0.0, 0.0))};
  c = rg::combine_ranges(failed, b, shifted, 0.0, &from);
  ASSERT_EQ(c.status, rg::RangeStatus::ok);
  EXPECT_EQ(from, rg::CombinedFrom::b);
  EXPECT_NEAR(c.distance_m, std::hypot(1.0, 21.0), 1e-9);
  EXPECT_DOUBLE_EQ(c.sigma_m, 0.2);

  // A range without a finite sigma is not combined.
  rg::TargetRange nan_sigma = b;
  nan_sigma.sigma_m = rg::TargetRange::nan;
  c = rg::combine_ranges(a, nan_sigma, report, 0.0, &from);
  EXPECT_EQ(from, rg::CombinedFrom::a);
  EXPECT_NEAR(c.distance_m, 20.0, 1e-9);
  EXPECT_DOUBLE_EQ(c.sigma_m, 0.1);

  // Both failed: no distance, and both reasons.
  rg::TargetRange none;
  none.status = rg::RangeStatus::no_matches;
  none.message = "no correspondence in the box";
  c = rg::combine_ranges(failed, none, report, 0.0, &from);
  EXPECT_EQ(from, rg::CombinedFrom::neither);
  EXPECT_EQ(c.status, rg::RangeStatus::too_few_points);
  EXPECT_TRUE(std::isnan(c.distance_m));
  EXPECT_NE(c.message.find("Eq. 34"), std::string::npos);
  EXPECT_NE(c.message.find("no correspondence"), std::string::npos);
}

TEST(RangeRegion, TheAnchorAtTheRegionsDisparityMovedByTheInsidesShare) {
  const rg::RangingGeometry g{visible_grid(), kBaseline, Eigen::Isometry3d::Identity()};
  const Eigen::Vector3d p = at_bearing(40.0, 0.2, 0.01);
  Eigen::Vector2d px;
  double d = 0;
  ASSERT_TRUE(rg::project_point(g.grid, kBaseline, p, px, d));
  thermovis::match::RegionDisparity region;
  region.status = thermovis::match::RegionStatus::ok;
  region.anchor = px;
  region.disparity_px = d;
  region.sigma_px = 0.02;
  region.pixels = 150;
  const cv::Rect box(static_cast<int>(px.x()) - 5, static_cast<int>(px.y()) - 20, 10, 40);
  rg::RangeOptions o;
  // All outline: the region is ranged where the outline is, not moved.
  region.contour_fraction = 1.0;
  rg::TargetRange r = rg::range_region(g, box, region, 0.12, o);
  ASSERT_EQ(r.status, rg::RangeStatus::ok) << r.message;
  EXPECT_NEAR(r.distance_m, 40.0, 1e-6);
  EXPECT_EQ(r.region_pixels, 150);
  EXPECT_NEAR((r.position_m - p).norm(), 0.0, 1e-6);
  // Half of it from the inside (the visible surface): half of the surface-to-centre offset.
  region.contour_fraction = 0.5;
  r = rg::range_region(g, box, region, 0.12, o);
  EXPECT_NEAR(r.distance_m, 40.06, 1e-6);
  // Sigma: Eq. 2 of the region's sigma and the floor, and the model's own error.
  const rg::PointTriangulation t = rg::triangulate(g.grid, kBaseline, px, d);
  const double px_sigma = std::hypot(0.02, o.systematic_disparity_px);
  EXPECT_NEAR(r.sigma_m, std::hypot(px_sigma * t.distance_per_px, o.region_model_sigma_m), 1e-9);
  // No alignment: a status that carries its reason, no number.
  region.status = thermovis::match::RegionStatus::flat;
  region.message = "the region is flat";
  r = rg::range_region(g, box, region, 0.12, o);
  EXPECT_EQ(r.status, rg::RangeStatus::no_region);
  EXPECT_NE(r.message.find("flat"), std::string::npos) << r.message;
  EXPECT_FALSE(std::isfinite(r.distance_m));
  // A disparity that does not triangulate (at or beyond infinity).
  region.status = thermovis::match::RegionStatus::ok;
  region.disparity_px = -0.5;
  r = rg::range_region(g, box, region, 0.12, o);
  EXPECT_EQ(r.status, rg::RangeStatus::no_region);
  EXPECT_FALSE(std::isfinite(r.distance_m));
}
