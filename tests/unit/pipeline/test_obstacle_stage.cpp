// The obstacle stage's report: stixel obstacles merged with the targets the target path ranged
// (a person once, with its range), the free space made no farther than a target, and the row of
// each column's free space on the grid.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/pipeline/obstacle_stage.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace pl = thermovis::pipeline;
namespace ob = thermovis::obstacle;

namespace {

const pl::PipelineGeometry& geometry() {
  static const auto g =
      pl::make_geometry(thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()), {});
  return g;
}

const pl::ObstacleStage& stage() {
  static const pl::ObstacleStage s(geometry());
  return s;
}

// The prior's ground in the reporting frame (the stage's ground when no pair found one).
ob::GroundPlane prior_ground() {
  return ob::plane_in_frame(ob::prior_plane(ob::GroundPrior{}), geometry().T_ref_reporting);
}

ob::Obstacle stixel_obstacle(cv::Rect box, double distance_m, int stixels = 6) {
  ob::Obstacle o;
  o.box = box;
  o.distance_m = distance_m;
  o.sigma_m = 0.1;
  o.position_m = {0.0, 0.5, distance_m};
  o.extent_m = {1.8, 1.5, 0.4};
  o.bands = ob::kVisibleBit;
  o.stixels = stixels;
  return o;
}

// A result whose free space is `free_m` in every column (NaN: no ground).
ob::ObstacleResult result_with(std::vector<ob::Obstacle> obstacles, float free_m) {
  ob::ObstacleResult r;
  r.obstacles = std::move(obstacles);
  r.free_space_m.assign(static_cast<std::size_t>(geometry().grid.width), free_m);
  return r;
}

// A person of thermovis/ranges: its centre `distance_m` ahead, 1 m above the ground.
pl::RangedTarget3d person(std::uint32_t id, cv::Rect box, double distance_m) {
  pl::RangedTarget3d t;
  t.target_id = id;
  t.label = "person";
  t.box = box;
  t.sigma_m = 0.05;
  t.position_m = {0.0, 0.4, distance_m};
  t.band = pl::Band::fused;
  return t;
}

}  // namespace

TEST(ObstacleStage, APersonIsReportedOnceWithItsRangeAndTheStixelsOverIt) {
  const cv::Rect person_box(400, 250, 20, 50);
  const ob::ObstacleResult r =
      result_with({stixel_obstacle({402, 260, 14, 38}, 19.8),   // the person's own stixels
                   stixel_obstacle({600, 240, 80, 60}, 30.0)},  // a car beside it
                  60.0f);
  const pl::ObstacleReport report = stage().report(r, {person(7, person_box, 20.0)});
  ASSERT_EQ(report.obstacles.size(), 2u);
  const pl::ReportedObstacle& p = report.obstacles[0];  // nearest first
  EXPECT_EQ(p.label, "person");
  ASSERT_TRUE(p.target_id.has_value());
  EXPECT_EQ(*p.target_id, 7u);
  EXPECT_EQ(p.obstacle.box, person_box);
  EXPECT_NEAR(p.obstacle.sigma_m, 0.05, 1e-12);
  EXPECT_EQ(p.obstacle.stixels, 6);
  EXPECT_EQ(p.obstacle.bands, ob::kVisibleBit | ob::kInfraredBit);
  EXPECT_NEAR(p.obstacle.extent_m.x(), 1.8, 1e-12);  // the stixels' measured extent
  // Horizontal: the range's position less its component along the ground's normal.
  const ob::GroundPlane ground = prior_ground();
  const Eigen::Vector3d at(0.0, 0.4, 20.0);
  EXPECT_NEAR(p.obstacle.distance_m, (at - ground.normal.dot(at) * ground.normal).norm(), 1e-9);
  EXPECT_NEAR(p.obstacle.distance_m, 20.0, 0.05);
  const pl::ReportedObstacle& car = report.obstacles[1];
  EXPECT_EQ(car.label, "obstacle");
  EXPECT_FALSE(car.target_id.has_value());
  EXPECT_DOUBLE_EQ(car.obstacle.distance_m, 30.0);
}

TEST(ObstacleStage, AnObstacleBehindAPersonOrMostlyBesideItStaysAnObstacle) {
  const cv::Rect person_box(400, 250, 20, 50);
  const ob::ObstacleResult r = result_with(
      {stixel_obstacle({404, 255, 12, 30}, 35.0),    // inside the box, 15 m behind
       stixel_obstacle({380, 250, 100, 60}, 20.0)},  // at its distance, mostly beside it
      60.0f);
  const pl::ObstacleReport report = stage().report(r, {person(3, person_box, 20.0)});
  ASSERT_EQ(report.obstacles.size(), 3u);
  int people = 0, obstacles = 0;
  for (const auto& o : report.obstacles) {
    people += o.label == "person";
    obstacles += o.label == "obstacle";
  }
  EXPECT_EQ(people, 1);
  EXPECT_EQ(obstacles, 2);
  // The person alone keeps the extent its box gives at its distance.
  for (const auto& o : report.obstacles) {
    if (!o.target_id) continue;
    EXPECT_EQ(o.obstacle.stixels, 0);
    EXPECT_NEAR(o.obstacle.extent_m.x(), 20.0 / geometry().grid.f * o.obstacle.distance_m, 1e-9);
  }
}

TEST(ObstacleStage, FreeSpaceEndsAtAPersonEvenWhereNoGroundWasFound) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const cv::Rect box(300, 250, 25, 60);
  const pl::ObstacleReport report = stage().report(result_with({}, nan), {person(1, box, 12.0)});
  ASSERT_EQ(report.free_space_m.size(), static_cast<std::size_t>(geometry().grid.width));
  for (int x = 0; x < geometry().grid.width; ++x) {
    const float fs = report.free_space_m[static_cast<std::size_t>(x)];
    if (x >= box.x && x < box.br().x) {
      EXPECT_NEAR(fs, report.obstacles[0].obstacle.distance_m, 1e-5) << x;
    } else {
      EXPECT_TRUE(std::isnan(fs)) << x;
    }
  }
  // Beyond its own free space, a person does not move it back.
  const pl::ObstacleReport near = stage().report(result_with({}, 5.0f), {person(1, box, 12.0)});
  EXPECT_FLOAT_EQ(near.free_space_m[310], 5.0f);
}

TEST(ObstacleStage, EachColumnsFreeSpaceRowIsWhereTheGroundIsThatFarAway) {
  std::vector<ob::Obstacle> none;
  ob::ObstacleResult r = result_with(none, 60.0f);
  const int w = geometry().grid.width;
  for (int x = 0; x < w; ++x) {
    r.free_space_m[static_cast<std::size_t>(x)] = static_cast<float>(5.0 + 50.0 * x / w);
  }
  r.free_space_m[17] = std::numeric_limits<float>::quiet_NaN();
  const pl::ObstacleReport report = stage().report(r, {});
  ASSERT_EQ(report.free_space_row.size(), static_cast<std::size_t>(w));
  EXPECT_TRUE(std::isnan(report.free_space_row[17]));
  const thermovis::camera::RectifiedCamera grid(geometry().grid);
  const Eigen::Matrix3d R =
      (geometry().T_ref_reporting.inverse() * geometry().visible.T_ref_left_rect).rotation();
  const ob::GroundPlane ground = prior_ground();
  int checked = 0;
  for (int x = 100; x < w - 100; x += 97) {
    const float row = report.free_space_row[static_cast<std::size_t>(x)];
    ASSERT_TRUE(std::isfinite(row)) << x;
    EXPECT_GT(row, geometry().grid.cy);  // below the horizon of a level rig
    // That pixel's ray meets the ground at the column's free-space distance.
    Eigen::Vector3d ray;
    ASSERT_TRUE(grid.unproject({static_cast<double>(x), row}, ray));
    ray = R * ray.normalized();
    const Eigen::Vector3d p = ground.height_m / ground.normal.dot(ray) * ray;
    const double horizontal = (p - ground.normal.dot(p) * ground.normal).norm();
    EXPECT_NEAR(horizontal, r.free_space_m[static_cast<std::size_t>(x)], 1e-3 * horizontal) << x;
    ++checked;
  }
  EXPECT_GE(checked, 5);
}

TEST(ObstacleStage, ATargetWithANonFinitePositionIsRefused) {
  pl::RangedTarget3d t = person(1, {300, 250, 25, 60}, 12.0);
  t.position_m.x() = std::nan("");
  EXPECT_THROW(stage().report(result_with({}, 60.0f), {t}), std::invalid_argument);
  t = person(1, {300, 250, 25, 60}, 12.0);
  t.sigma_m = -1;
  EXPECT_THROW(stage().report(result_with({}, 60.0f), {t}), std::invalid_argument);
}

TEST(ObstacleStage, TheReductionFollowsTheGridSoTheCostDoesNot) {
  EXPECT_EQ(stage().options().obstacles.reduction, 2);  // the pipeline grid, 417 px/rad
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  pl::GridOptions full;
  full.scale = 1.0;
  const pl::ObstacleStage on_full(pl::make_geometry(rig, full));
  EXPECT_EQ(on_full.options().obstacles.reduction, 4);
  EXPECT_NEAR(on_full.detector().reduced_grid(ob::PairBand::visible).width,
              stage().detector().reduced_grid(ob::PairBand::visible).width, 1);
  pl::ObstacleStageOptions fixed;
  fixed.reduced_px_per_rad = 0;
  fixed.obstacles.reduction = 3;
  EXPECT_EQ(pl::ObstacleStage(geometry(), fixed).options().obstacles.reduction, 3);
}

TEST(ObstacleStage, NeitherPairIsRefused) {
  pl::ObstacleStageOptions o;
  o.visible = false;
  o.infrared = false;
  EXPECT_THROW(pl::ObstacleStage(geometry(), o), std::invalid_argument);
}
