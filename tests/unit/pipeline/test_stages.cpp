// The match, range and detect stages on synthetic pairs: the bands each choice matches on, the
// infrared counts' own stretch, and the errors a wrong input gets.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "thermovis/pipeline/detect_stage.hpp"
#include "thermovis/pipeline/match_stage.hpp"
#include "thermovis/pipeline/range_stage.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace pl = thermovis::pipeline;

namespace {

const pl::PipelineGeometry& geometry() {
  static const auto g =
      pl::make_geometry(thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()), {});
  return g;
}

// A blurred-noise texture on the grid and the same shifted left by `shift` columns (a
// fronto-parallel scene at one disparity), as grey and as infrared counts (8000 + 4 x grey).
struct Pairs {
  explicit Pairs(int shift) {
    const cv::Size grid = geometry().grid_size();
    cv::Mat noise(grid, CV_8UC1);
    cv::RNG rng(7);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(noise, grey_left, cv::Size(5, 5), 1.2);
    grey_right = cv::Mat::zeros(grid, CV_8UC1);
    grey_left.colRange(shift, grid.width).copyTo(grey_right.colRange(0, grid.width - shift));
    grey_left.convertTo(counts_left, CV_16U, 4, 8000);
    grey_right.convertTo(counts_right, CV_16U, 4, 8000);
  }
  pl::MatchImages images(bool flat_visible = false) const {
    if (!flat_visible) return {grey_left, grey_right, counts_left, counts_right, {}};
    const cv::Mat flat(grey_left.size(), CV_8UC1, cv::Scalar(90));
    return {flat, flat.clone(), counts_left, counts_right, {}};
  }
  cv::Mat grey_left, grey_right, counts_left, counts_right;
};

pl::MatchStage stage(pl::BandChoice band) {
  pl::MatchStageOptions o;
  o.band = band;
  return pl::MatchStage(geometry(), o);
}

const cv::Rect kBox(400, 250, 40, 60);

}  // namespace

TEST(MatchStage, EachChoiceMatchesItsPairsAtTheTrueDisparity) {
  const Pairs pairs(12);
  const auto both = stage(pl::BandChoice::both).match(pairs.images(), kBox);
  ASSERT_EQ(both.size(), 2u);
  EXPECT_EQ(both[0].band, pl::Band::visible);  // the primary pair first
  EXPECT_EQ(both[1].band, pl::Band::infrared);
  for (const auto& band : both) {
    ASSERT_GE(band.result.matches.size(), 10u) << pl::band_name(band.band);
    for (const auto& c : band.result.matches) {
      EXPECT_NEAR(c.disparity_px, 12.0, 0.1) << pl::band_name(band.band);
      EXPECT_TRUE(
          kBox.contains(cv::Point(static_cast<int>(c.left.x()), static_cast<int>(c.left.y()))));
    }
  }
  const auto visible = stage(pl::BandChoice::visible).match(pairs.images(), kBox);
  ASSERT_EQ(visible.size(), 1u);
  EXPECT_EQ(visible[0].band, pl::Band::visible);
  const auto infrared = stage(pl::BandChoice::infrared).match(pairs.images(), kBox);
  ASSERT_EQ(infrared.size(), 1u);
  EXPECT_EQ(infrared[0].band, pl::Band::infrared);
  // auto: the visible pair while it has points, the infrared one where it is flat.
  const auto automatic = stage(pl::BandChoice::automatic);
  EXPECT_EQ(automatic.match(pairs.images(), kBox).at(0).band, pl::Band::visible);
  EXPECT_EQ(automatic.match(pairs.images(true), kBox).at(0).band, pl::Band::infrared);
  // A pair that is not there is left out, not invented.
  pl::MatchImages no_infrared = pairs.images();
  no_infrared.infrared_left = no_infrared.infrared_right = cv::Mat();
  EXPECT_EQ(stage(pl::BandChoice::both).match(no_infrared, kBox).size(), 1u);
  EXPECT_TRUE(stage(pl::BandChoice::infrared).match(no_infrared, kBox).empty());
}

TEST(MatchStage, ImagesOffTheGridOrOfTheWrongTypeAreNamed) {
  const Pairs pairs(12);
  const auto matcher = stage(pl::BandChoice::both);
  pl::MatchImages small = pairs.images();
  small.primary_left = small.primary_left(cv::Rect(0, 0, 100, 100)).clone();
  EXPECT_THROW(matcher.match(small, kBox), std::invalid_argument);
  pl::MatchImages grey_infrared = pairs.images();
  grey_infrared.infrared_left = pairs.grey_left;
  grey_infrared.infrared_right = pairs.grey_right;
  try {
    matcher.match(grey_infrared, kBox);
    ADD_FAILURE() << "8-bit infrared was matched as counts";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("infrared pair must be 16-bit counts"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(pl::MatchStage::stage_grey(cv::Mat(4, 4, CV_32FC1)), std::invalid_argument);
}

TEST(MatchStage, EachBoxOfACaptureOnWorkerThreadsAsAlone) {
  const Pairs pairs(12);
  const auto matcher = stage(pl::BandChoice::both);
  const std::vector<pl::MatchStage::Box> boxes = {{kBox, "person"},
                                                  {cv::Rect(100, 80, 12, 30), "person"},
                                                  {cv::Rect(600, 300, 90, 140), ""},
                                                  {cv::Rect(250, 400, 20, 50), "person"},
                                                  {cv::Rect(700, 100, 30, 30), "car"}};
  const int threads = cv::getNumThreads();
  cv::setNumThreads(2);
  const auto each = matcher.match_each(pairs.images(), boxes);
  cv::setNumThreads(threads);
  ASSERT_EQ(each.size(), boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const auto alone = matcher.match(pairs.images(), boxes[i].box, boxes[i].label);
    ASSERT_EQ(each[i].size(), alone.size()) << "box " << i;
    for (std::size_t b = 0; b < alone.size(); ++b) {
      const auto& got = each[i][b].result;
      const auto& want = alone[b].result;
      EXPECT_EQ(each[i][b].band, alone[b].band);
      ASSERT_EQ(got.matches.size(), want.matches.size()) << "box " << i;
      ASSERT_FALSE(want.matches.empty()) << "box " << i;
      for (std::size_t k = 0; k < want.matches.size(); ++k) {
        EXPECT_EQ(got.matches[k].left, want.matches[k].left);
        EXPECT_EQ(got.matches[k].disparity_px, want.matches[k].disparity_px);
      }
      ASSERT_EQ(got.region.ok(), want.region.ok());
      if (want.region.ok()) {
        EXPECT_EQ(got.region.disparity_px, want.region.disparity_px);
      }
    }
  }
  // A bad capture's error comes back to the caller from the workers.
  pl::MatchImages small = pairs.images();
  small.primary_left = small.primary_left(cv::Rect(0, 0, 100, 100)).clone();
  cv::setNumThreads(2);
  EXPECT_THROW(matcher.match_each(small, boxes), std::invalid_argument);
  cv::setNumThreads(threads);
  EXPECT_TRUE(matcher.match_each(pairs.images(), {}).empty());
}

TEST(RangeStage, CombinesTwoPairsAndRefusesTwoEntriesOfOne) {
  const Pairs pairs(12);
  const auto both = stage(pl::BandChoice::both).match(pairs.images(), kBox);
  ASSERT_EQ(both.size(), 2u);
  const pl::RangeStage ranger(geometry());
  const pl::TargetEntry visible{pl::Band::visible, "wall", kBox, both[0].result.matches,
                                both[0].result.region};
  const pl::TargetEntry infrared{pl::Band::infrared, "wall", kBox, both[1].result.matches,
                                 both[1].result.region};
  const pl::RangedTarget v = ranger.range({visible});
  const pl::RangedTarget i = ranger.range({infrared});
  const pl::RangedTarget f = ranger.range({visible, infrared});
  ASSERT_TRUE(v.ok() && i.ok() && f.ok());
  EXPECT_EQ(f.band, pl::Band::fused);
  EXPECT_LT(f.range.sigma_m, std::min(v.range.sigma_m, i.range.sigma_m));
  // 12 px on each pair's own baseline: the two pairs' distances differ by their baselines.
  EXPECT_NEAR(v.distance_m / i.distance_m,
              geometry().visible.baseline_m / geometry().infrared.baseline_m, 0.03);
  EXPECT_THROW(ranger.range({visible, visible}), std::invalid_argument);
  EXPECT_THROW(ranger.range({}), std::invalid_argument);
  // No points: a status, never a number.
  const pl::RangedTarget none = ranger.range({{pl::Band::visible, "person", kBox, {}, {}}});
  EXPECT_FALSE(none.ok());
  EXPECT_FALSE(none.range.message.empty());
}

// A box whose few points hold a nearer group of 30 % (a repeated texture matched one period
// off) and whose whole region aligned at the target's disparity: the points near the region
// range it, not the nearer group; points that lie nowhere near the region give way to it.
TEST(RangeStage, TheRegionChoosesAmongTheGroupsOfAFewPoints) {
  const Pairs pairs(12);
  pl::MatchStageOptions always;
  always.band = pl::BandChoice::visible;
  always.region_below_points = 1 << 20;
  const auto matched = pl::MatchStage(geometry(), always).match(pairs.images(), kBox);
  ASSERT_EQ(matched.size(), 1u);
  const auto& region = matched[0].result.region;
  ASSERT_TRUE(region.ok()) << region.message;
  ASSERT_GE(matched[0].result.matches.size(), 10u);
  std::vector<thermovis::match::Correspondence> points(matched[0].result.matches.begin(),
                                                       matched[0].result.matches.begin() + 10);
  for (int k : {1, 4, 7}) {  // 18 px instead of 12: a third nearer
    points[static_cast<size_t>(k)].disparity_px += 6.0;
    points[static_cast<size_t>(k)].right.x() -= 6.0;
  }
  const auto range = [&](pl::RangeEstimate estimate, const thermovis::match::RegionDisparity& r,
                         const std::vector<thermovis::match::Correspondence>& p) {
    pl::RangeStageOptions o;
    o.estimate = estimate;
    return pl::RangeStage(geometry(), o).range({{pl::Band::visible, "wall", kBox, p, r}});
  };
  const pl::RangedTarget by_region = range(pl::RangeEstimate::region, region, points);
  const pl::RangedTarget by_points = range(pl::RangeEstimate::points, region, points);
  const pl::RangedTarget both = range(pl::RangeEstimate::both, region, points);
  ASSERT_TRUE(by_region.ok() && by_points.ok() && both.ok()) << both.range.message;
  EXPECT_LT(by_points.distance_m, 0.8 * by_region.distance_m);  // the nearer group alone
  EXPECT_NEAR(both.distance_m, by_region.distance_m, 0.02 * by_region.distance_m);
  EXPECT_GE(both.range.points_used, 3);  // of the seven at 12 px
  EXPECT_LE(both.range.points_used, 7);
  // The points kept are named (bench ranging --points traces them), all of the seven.
  ASSERT_EQ(both.range.used.size(), static_cast<std::size_t>(both.range.points_used));
  for (int k : both.range.used)
    EXPECT_NEAR(points.at(static_cast<std::size_t>(k)).disparity_px, 12.0, 0.5);
  // Every point a third nearer than the region: the region's range alone.
  for (auto& c : points) {
    c.disparity_px += 6.0;
    c.right.x() -= 6.0;
  }
  const pl::RangedTarget apart = range(pl::RangeEstimate::both, region, points);
  ASSERT_TRUE(apart.ok()) << apart.range.message;
  EXPECT_NEAR(apart.distance_m, by_region.distance_m, 1e-6 * by_region.distance_m);
  EXPECT_EQ(apart.range.points_used, 0);
  // Every point 0.8 px nearer than the region (within the group screen's two windows of it, but
  // many sigma from it: a region aligned partly off the target): the points' range alone.
  points.assign(matched[0].result.matches.begin(), matched[0].result.matches.begin() + 10);
  for (auto& c : points) {
    c.disparity_px += 0.8;
    c.right.x() -= 0.8;
  }
  const pl::RangedTarget points_only = range(pl::RangeEstimate::points, region, points);
  const pl::RangedTarget off = range(pl::RangeEstimate::both, region, points);
  ASSERT_TRUE(points_only.ok() && off.ok()) << off.range.message;
  EXPECT_LT(off.distance_m, 0.97 * by_region.distance_m);
  EXPECT_NEAR(off.distance_m, points_only.distance_m, 1e-9 * points_only.distance_m);
  EXPECT_EQ(off.range.region_pixels, 0);
}

// Two pairs that disagree: the visible pair's seven points hold four a third nearer (a texture
// matched a period off: the nearer group keeps them) and three at the target; the infrared
// pair's points all see the target. The visible points grouped about the infrared range give
// the fused range; when none of them lies there, the uncertainty covers both ranges.
TEST(RangeStage, APairWhosePointsAlsoHoldTheOtherPairsRangeGivesWay) {
  const Pairs pairs(12);
  const auto matched = stage(pl::BandChoice::both).match(pairs.images(), kBox);
  ASSERT_EQ(matched.size(), 2u);
  ASSERT_GE(matched[0].result.matches.size(), 7u);
  const auto shifted = [](thermovis::match::Correspondence c, double by) {
    c.disparity_px += by;
    c.right.x() -= by;
    return c;
  };
  std::vector<thermovis::match::Correspondence> visible(matched[0].result.matches.begin(),
                                                        matched[0].result.matches.begin() + 7);
  const pl::RangeStage ranger(geometry());
  const pl::RangedTarget truth = ranger.range({{pl::Band::visible, "wall", kBox, visible, {}}});
  ASSERT_TRUE(truth.ok()) << truth.range.message;
  for (int k : {0, 2, 4, 6}) visible[static_cast<size_t>(k)] = shifted(visible[k], 6.0);
  // The infrared points at the disparity the target's distance has on that pair's baseline.
  std::vector<thermovis::match::Correspondence> infrared;
  const double scale = geometry().infrared.baseline_m / geometry().visible.baseline_m;
  for (const auto& c : matched[1].result.matches)
    infrared.push_back(shifted(c, c.disparity_px * (scale - 1.0)));
  const pl::TargetEntry ir{pl::Band::infrared, "wall", kBox, infrared, {}};
  const pl::RangedTarget alone = ranger.range({{pl::Band::visible, "wall", kBox, visible, {}}});
  ASSERT_TRUE(alone.ok()) << alone.range.message;
  EXPECT_LT(alone.distance_m, 0.8 * truth.distance_m);  // the nearer four
  const pl::RangedTarget fused = ranger.range({{pl::Band::visible, "wall", kBox, visible, {}}, ir});
  ASSERT_TRUE(fused.ok()) << fused.range.message;
  EXPECT_EQ(fused.band, pl::Band::fused);
  EXPECT_NEAR(fused.distance_m, truth.distance_m, 0.03 * truth.distance_m);
  // No visible point at the infrared range: both ranges within the combined uncertainty.
  for (auto& c : visible)
    if (c.disparity_px < 15.0) c = shifted(c, 6.0);
  const pl::RangedTarget near = ranger.range({{pl::Band::visible, "wall", kBox, visible, {}}});
  const pl::RangedTarget apart = ranger.range({{pl::Band::visible, "wall", kBox, visible, {}}, ir});
  ASSERT_TRUE(near.ok() && apart.ok()) << apart.range.message;
  EXPECT_GE(apart.range.sigma_m, 0.45 * (truth.distance_m - near.distance_m));
}

// Few points, or a nearer group among a box's points than their median's (a repeated texture
// matched one period off): the region is aligned to choose between the groups. Points that
// agree, a farther group (the background behind the target), or a near target's hundreds of
// points: the points alone.
TEST(MatchStage, AlignsTheRegionOfFewPointsOrOfPointsWithANearerGroup) {
  const pl::MatchStage s = stage(pl::BandChoice::visible);
  const auto points = [](std::vector<std::pair<int, double>> groups) {
    thermovis::match::MatchResult r;
    for (const auto& [count, disparity] : groups) {
      for (int i = 0; i < count; ++i) {
        thermovis::match::Correspondence c;
        c.disparity_px = disparity + 0.01 * i;
        r.matches.push_back(c);
      }
    }
    return r;
  };
  EXPECT_TRUE(s.aligns(points({{11, 11.1}})));
  EXPECT_FALSE(s.aligns(points({{20, 11.1}})));
  EXPECT_TRUE(s.aligns(points({{9, 11.1}, {4, 16.6}})));     // one period off: nearer
  EXPECT_FALSE(s.aligns(points({{10, 11.1}, {2, 16.6}})));   // two strays: no group
  EXPECT_FALSE(s.aligns(points({{9, 11.1}, {6, 5.0}})));     // the background: farther
  EXPECT_TRUE(s.aligns(points({{6, 11.1}, {9, 5.0}})));      // the target a minority in front
  EXPECT_FALSE(s.aligns(points({{30, 11.1}, {10, 16.6}})));  // a near target's many points
  pl::MatchStageOptions none;
  none.region = false;
  EXPECT_FALSE(pl::MatchStage(geometry(), none).aligns(points({{3, 11.1}})));
}

TEST(MatchStage, AlignsEachBoxsWholeRegionOnEveryPair) {
  const Pairs pairs(12);
  // By default a box with 12 points or more is ranged from its points alone.
  const auto by_points = stage(pl::BandChoice::both).match(pairs.images(), kBox);
  ASSERT_EQ(by_points.size(), 2u);
  EXPECT_EQ(by_points[0].result.region.status, thermovis::match::RegionStatus::not_aligned);
  pl::MatchStageOptions always;
  always.band = pl::BandChoice::both;
  always.region_below_points = 1 << 20;
  const pl::MatchStage aligner(geometry(), always);
  const auto both = aligner.match(pairs.images(), kBox);
  ASSERT_EQ(both.size(), 2u);
  for (const auto& band : both) {
    const auto& region = band.result.region;
    ASSERT_TRUE(region.ok()) << pl::band_name(band.band) << ": " << region.message;
    EXPECT_NEAR(region.disparity_px, 12.0, 0.02) << pl::band_name(band.band);
    // On the whole box (the texture does not split into a silhouette), in grid pixels.
    EXPECT_TRUE(kBox.contains(
        cv::Point(static_cast<int>(region.anchor.x()), static_cast<int>(region.anchor.y()))));
  }
  // A flat visible pair has no region; the infrared one still has.
  const auto flat = aligner.match(pairs.images(true), kBox);
  ASSERT_EQ(flat.size(), 2u);
  EXPECT_EQ(flat[0].result.region.status, thermovis::match::RegionStatus::flat);
  EXPECT_TRUE(flat[1].result.region.ok());
  // The range stage ranges a box from its region alone, from its points alone, or both.
  for (auto estimate :
       {pl::RangeEstimate::points, pl::RangeEstimate::region, pl::RangeEstimate::both}) {
    pl::RangeStageOptions o;
    o.estimate = estimate;
    const pl::RangedTarget r = pl::RangeStage(geometry(), o)
                                   .range({{pl::Band::visible, "wall", kBox, both[0].result.matches,
                                            both[0].result.region}});
    ASSERT_TRUE(r.ok()) << r.range.message;
    EXPECT_EQ(r.range.region_pixels > 0, estimate != pl::RangeEstimate::points);
    EXPECT_EQ(r.range.points_used > 0, estimate != pl::RangeEstimate::region);
  }
  // Region only, without a region: a status naming it.
  pl::RangeStageOptions region_only;
  region_only.estimate = pl::RangeEstimate::region;
  const pl::RangedTarget none = pl::RangeStage(geometry(), region_only)
                                    .range({{pl::Band::visible, "wall", kBox,
                                             both[0].result.matches, flat[0].result.region}});
  EXPECT_EQ(none.range.status, thermovis::range::RangeStatus::no_region);
  EXPECT_NE(none.range.message.find("flat"), std::string::npos) << none.range.message;
  EXPECT_THROW(pl::parse_range_estimate("corners"), std::invalid_argument);
}

// On the full grid (twice the pipeline grid's px per rad) the detector runs on the grid reduced
// by 2 and its boxes come back in the grid's pixels: a warm person standing 20 m ahead is found
// there, once, with a box around it. reduced_px_per_rad 0 detects on the grid itself, and a
// wrong-sized image is refused.
TEST(DetectStage, DetectsOnTheFullGridReducedToThePipelines) {
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  pl::GridOptions full;
  full.scale = 1.0;
  full.infrared_reduction = 1;  // the infrared pair on the full grid itself
  const auto geometry_full = pl::make_geometry(rig, full);
  full.infrared_reduction = 0;  // at the infrared cameras' own resolution
  const auto geometry_own = pl::make_geometry(rig, full);
  ASSERT_EQ(geometry_own.infrared_reduction, 2);
  EXPECT_EQ(pl::DetectStage(geometry()).reduction(), 1);
  const pl::DetectStage reduced(geometry_full);
  ASSERT_EQ(reduced.reduction(), 2);
  pl::DetectOptions own;
  own.reduced_px_per_rad = 0;
  const pl::DetectStage unreduced(geometry_full, own);
  EXPECT_EQ(unreduced.reduction(), 1);
  // The infrared images already at their cameras' resolution are not reduced again; the
  // boxes still come on the grid.
  const pl::DetectStage on_own(geometry_own);
  EXPECT_EQ(on_own.reduction(), 1);
  const auto& g = geometry_full.grid;
  cv::Mat counts(geometry_full.grid_size(), CV_16UC1);
  cv::randn(counts, 8000, 30);
  const int top = static_cast<int>(g.cy + g.f * std::atan((1.4 - 1.75) / 20.0));
  const int foot = static_cast<int>(g.cy + g.f * std::atan(1.4 / 20.0));
  const cv::Rect person(static_cast<int>(g.cx) + 101, top, static_cast<int>(g.f * 0.5 / 20.0),
                        foot - top);
  counts(person).setTo(9500);
  cv::Mat counts_own;
  const cv::Size own_size = geometry_own.image_size(pl::Band::infrared);
  cv::resize(counts(cv::Rect(0, 0, own_size.width * 2, own_size.height * 2)), counts_own, own_size,
             0, 0, cv::INTER_AREA);
  const std::pair<const pl::DetectStage*, const cv::Mat*> cases[] = {
      {&reduced, &counts}, {&unreduced, &counts}, {&on_own, &counts_own}};
  for (const auto& [stage, image] : cases) {
    const auto found = stage->detect(*image);
    std::vector<cv::Rect> on_person;  // (i.i.d. noise makes small warm specks elsewhere)
    for (const auto& d : found)
      if ((d.box & person).area() > person.area() / 2) on_person.push_back(d.box);
    ASSERT_EQ(on_person.size(), 1u) << "image " << image->cols << "x" << image->rows;
    // The blob's 3 x 5 px closing pads its box by a few pixels of the image it ran on (twice
    // as many grid pixels when reduced): the box holds the person and not twice its area.
    const cv::Rect box = on_person[0];
    EXPECT_EQ(box & person, person) << box;
    EXPECT_LE(box.area(), 2 * person.area()) << box;
  }
  EXPECT_THROW(reduced.detect(cv::Mat(geometry().grid_size(), CV_16UC1, cv::Scalar(8000))),
               std::invalid_argument);
  EXPECT_THROW(on_own.detect(counts), std::invalid_argument);  // not the infrared pair's grid
  pl::DetectOptions bad;
  bad.reduced_px_per_rad = -1;
  EXPECT_THROW(pl::DetectStage(geometry_full, bad), std::invalid_argument);
}

TEST(DetectStage, FindsAWarmPersonAndRefusesColour) {
  const pl::DetectStage detector(geometry());
  const cv::Size grid = geometry().grid_size();
  cv::Mat counts(grid, CV_16UC1);
  cv::randn(counts, 8000, 30);
  // A warm block the size of a person standing on the ground 10 m ahead (rig 1.4 m high).
  const auto& g = geometry().grid;
  const int top = static_cast<int>(g.cy + g.f * std::atan((1.4 - 1.75) / 10.0));
  const int foot = static_cast<int>(g.cy + g.f * std::atan(1.4 / 10.0));
  const cv::Rect person(static_cast<int>(g.cx), top, static_cast<int>(g.f * 0.5 / 10.0),
                        foot - top);
  counts(person).setTo(9500);
  const auto found = detector.detect(counts);
  int on_person = 0;
  for (const auto& d : found) on_person += (d.box & person).area() > person.area() / 2;
  EXPECT_EQ(on_person, 1) << found.size() << " detections";
  EXPECT_THROW(detector.detect(cv::Mat(grid, CV_8UC3)), std::invalid_argument);
}
