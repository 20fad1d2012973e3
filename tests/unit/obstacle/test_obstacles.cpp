// The obstacle detector on exact synthetic disparity maps (a road, a box standing on it, a wall,
// the sky) and on simulated street captures rectified as the pipeline does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/obstacle/obstacles.hpp"
#include "thermovis/obstacle/robust.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace ob = thermovis::obstacle;
namespace cam = thermovis::camera;
namespace rg = thermovis::range;

namespace {

constexpr double kBaseline = 0.3, kHeight = 1.4;

// A grid like the pipeline's (equirectangular, 120 deg wide) and a level pair on it.
cam::RectifiedIntrinsics synthetic_grid() {
  cam::RectifiedIntrinsics g;
  g.width = 800;
  g.height = 480;
  g.f = 380;
  g.cx = 399.5;
  g.cy = 239.5;
  return g;
}

ob::ObstacleDetector synthetic_detector(const ob::ObstacleOptions& options = {}) {
  const cam::RectifiedIntrinsics g = synthetic_grid();
  const rg::RangingGeometry pair{cam::RectifiedCamera(g), kBaseline, Eigen::Isometry3d::Identity()};
  return ob::ObstacleDetector(g, {{ob::PairBand::visible, pair}}, Eigen::Isometry3d::Identity(),
                              ob::GroundPrior{kHeight, 0.0, 0.0}, options);
}

// A box's face towards the rig: z = distance, x in [x0, x1], from the ground up to height.
struct Face {
  double distance_m, x0, x1, height_m;
};

// The exact disparity (1/16 px steps, as the matchers give) of the reduced grid's pixels on the
// ground y = kHeight (to 80 m) and the faces; NaN where the ray meets nothing (sky). `wall_m`
// > 0: a wall across the whole view at that distance instead.
// `right_centre` non-zero: the right eye there (left rectified frame), off the grid's axis, as
// the pipeline's infrared pair is; its column is that of the angle out of the y-z plane from it.
cv::Mat synthetic_disparity(const ob::ObstacleDetector& d, const std::vector<Face>& faces,
                            double wall_m = 0, ob::PairBand band = ob::PairBand::visible,
                            const Eigen::Vector3d& right_centre = Eigen::Vector3d::Zero()) {
  const cam::RectifiedCamera grid(d.reduced_grid(band));
  const auto& r = grid.intrinsics();
  cv::Mat out(r.height, r.width, CV_32F, cv::Scalar(NAN));
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x) {
      Eigen::Vector3d u;
      if (!grid.unproject({x, y}, u)) continue;
      u.normalize();
      double t = u.y() > 0 ? kHeight / u.y() : INFINITY;
      if (t > 80) t = INFINITY;
      if (wall_m > 0 && u.z() > 0) t = wall_m / u.z();
      for (const Face& f : faces) {
        if (!(u.z() > 0)) continue;
        const double tf = f.distance_m / u.z();
        const Eigen::Vector3d p = tf * u;
        if (tf < t && p.x() >= f.x0 && p.x() <= f.x1 && p.y() <= kHeight &&
            p.y() >= kHeight - f.height_m) {
          t = tf;
        }
      }
      if (!std::isfinite(t)) continue;
      Eigen::Vector2d px;
      double disparity = 0;
      if (right_centre.isZero()) {
        if (!rg::project_point(grid, kBaseline, t * u, px, disparity)) continue;
      } else {
        const Eigen::Vector3d from_right = t * u - right_centre;
        disparity = x - grid.column_of_alpha(std::asin(from_right.x() / from_right.norm()));
      }
      out.at<float>(y, x) = static_cast<float>(std::round(disparity * 16) / 16);
    }
  return out;
}

}  // namespace

TEST(ObstacleDetector, AnEmptyRoadHasItsGroundAndNoObstacle) {
  const ob::ObstacleDetector d = synthetic_detector();
  const ob::PairObstacles r = d.from_disparity(ob::PairBand::visible, synthetic_disparity(d, {}));
  ASSERT_TRUE(r.ok()) << r.ground.message;
  EXPECT_NEAR(r.ground.plane.height_m, kHeight, 0.01);
  EXPECT_TRUE(r.obstacles.empty()) << r.obstacles.size() << " obstacles, the first at "
                                   << r.obstacles.front().distance_m << " m";
  // Free all the way in the middle of the view.
  EXPECT_FLOAT_EQ(r.free_space_m[400], static_cast<float>(d.options().max_distance_m));
}

TEST(ObstacleDetector, ABoxOnTheRoadIsFoundAtItsDistance) {
  // A box 1 m wide and 0.8 m high, its face 12 m ahead, and a pole-like one at 6 m to the left.
  const ob::ObstacleDetector d = synthetic_detector();
  const ob::PairObstacles r =
      d.from_disparity(ob::PairBand::visible,
                       synthetic_disparity(d, {{12.0, 0.5, 1.5, 0.8}, {6.0, -2.2, -1.9, 2.0}}));
  ASSERT_TRUE(r.ok()) << r.ground.message;
  ASSERT_EQ(r.obstacles.size(), 2u);
  // Nearest first: the pole at 6 m (its face's nearest column about 6.3 m away horizontally).
  const ob::Obstacle& pole = r.obstacles[0];
  const ob::Obstacle& box = r.obstacles[1];
  EXPECT_NEAR(pole.distance_m, std::hypot(6.0, 1.9), 0.15);
  EXPECT_NEAR(box.distance_m, std::hypot(12.0, 0.5), 0.3);
  EXPECT_GT(box.sigma_m, 0.0);
  EXPECT_LT(box.sigma_m, 0.5);
  EXPECT_NEAR(box.extent_m.x(), 1.0, 0.25);  // width
  EXPECT_NEAR(box.extent_m.y(), 0.8, 0.2);   // height above the ground
  EXPECT_NEAR(pole.extent_m.y(), 2.0, 0.3);
  EXPECT_NEAR(box.position_m.z(), 12.0, 0.3);
  EXPECT_NEAR(box.position_m.x(), 1.0, 0.2);
  EXPECT_EQ(box.bands, ob::kVisibleBit);
  // Its box on the grid holds the face's centre; the free space in front of it is its distance.
  Eigen::Vector2d centre;
  cam::RectifiedCamera(synthetic_grid()).project(Eigen::Vector3d(1.0, kHeight - 0.4, 12.0), centre);
  EXPECT_TRUE(
      box.box.contains(cv::Point(static_cast<int>(centre.x()), static_cast<int>(centre.y()))))
      << "box " << box.box << ", face centre " << centre.transpose();
  EXPECT_NEAR(r.free_space_m[static_cast<std::size_t>(centre.x())], box.distance_m, 0.3);
}

// A person 18 m away passing behind one 15 m away: the blocks across the nearer one's edge
// range in between (a sliver at 16.5 m here, two columns wide), and each neighbour is within
// the clustering tolerance of the next. Two obstacles, each at its own distance, not one that
// spans both at the nearer's.
TEST(ObstacleDetector, MixedColumnsAtAnEdgeDoNotChainANearAndAFarObject) {
  const ob::ObstacleDetector d = synthetic_detector();
  const double column_rad =
      1.0 / cam::RectifiedCamera(d.reduced_grid(ob::PairBand::visible)).intrinsics().f;
  const double edge = std::atan(1.0 / 15.0);  // the near person's right edge
  const double sliver_end = edge + 2 * column_rad;
  const std::vector<Face> faces = {
      {15.0, 0.0, 1.0, 1.75},
      {16.5, 16.5 * std::tan(edge), 16.5 * std::tan(sliver_end), 1.75},
      {18.0, 18.0 * std::tan(sliver_end), 18.0 * std::tan(sliver_end) + 1.0, 1.75}};
  const ob::PairObstacles r =
      d.from_disparity(ob::PairBand::visible, synthetic_disparity(d, faces));
  ASSERT_TRUE(r.ok()) << r.ground.message;
  const auto near_to = [&](double distance_m) {
    return std::count_if(r.obstacles.begin(), r.obstacles.end(), [&](const ob::Obstacle& o) {
      return std::abs(o.distance_m - distance_m) < 0.05 * distance_m;
    });
  };
  for (const auto& o : r.obstacles) std::cout << o.distance_m << " m, " << o.box << "\n";
  EXPECT_EQ(near_to(15.0), 1);
  EXPECT_EQ(near_to(18.0), 1);
}

TEST(ObstacleDetector, ARightEyeOffTheGridsAxisIsTriangulatedWhereItIs) {
  // The pipeline's infrared pair: its right eye 0.35 m along the grid's x axis and 67 mm off
  // it. A box 37-39 deg to the right, where taking the eye as on the axis would move it by
  // several per cent.
  const cam::RectifiedIntrinsics g = synthetic_grid();
  const Eigen::Vector3d right(0.35, 0.06, 0.03);
  rg::RangingGeometry pair{cam::RectifiedCamera(g), right.x(), Eigen::Isometry3d::Identity()};
  pair.right_centre_m = right;
  const ob::ObstacleDetector d(g, {{ob::PairBand::infrared, pair}}, Eigen::Isometry3d::Identity(),
                               ob::GroundPrior{kHeight, 0.0, 0.0});
  const ob::PairObstacles r = d.from_disparity(
      ob::PairBand::infrared,
      synthetic_disparity(d, {{8.0, 5.5, 6.5, 1.0}}, 0, ob::PairBand::infrared, right));
  ASSERT_TRUE(r.ok()) << r.ground.message;
  EXPECT_NEAR(r.ground.plane.height_m, kHeight, 0.02);
  ASSERT_EQ(r.obstacles.size(), 1u);
  EXPECT_NEAR(r.obstacles[0].distance_m, std::hypot(8.0, 5.5), 0.02 * std::hypot(8.0, 5.5));
  EXPECT_EQ(r.obstacles[0].bands, ob::kInfraredBit);
}

TEST(ObstacleDetector, ALowKerbIsNotAnObstacle) {
  // 0.1 m high: below min_obstacle_height_m.
  const ob::ObstacleDetector d = synthetic_detector();
  const ob::PairObstacles r =
      d.from_disparity(ob::PairBand::visible, synthetic_disparity(d, {{8.0, -3.0, 3.0, 0.1}}));
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.obstacles.empty());
}

TEST(ObstacleDetector, AWallOrTheSkyGiveAStatusAndNoObstacle) {
  const ob::ObstacleDetector d = synthetic_detector();
  const ob::PairObstacles wall =
      d.from_disparity(ob::PairBand::visible, synthetic_disparity(d, {}, 3.0));
  EXPECT_EQ(wall.ground.status, ob::GroundStatus::no_ground) << wall.ground.message;
  EXPECT_TRUE(wall.obstacles.empty());
  EXPECT_TRUE(std::all_of(wall.free_space_m.begin(), wall.free_space_m.end(),
                          [](float v) { return std::isnan(v); }));
  const auto& r = d.reduced_grid(ob::PairBand::visible);
  const ob::PairObstacles sky =
      d.from_disparity(ob::PairBand::visible, cv::Mat(r.height, r.width, CV_32F, cv::Scalar(NAN)));
  EXPECT_EQ(sky.ground.status, ob::GroundStatus::no_disparity);
  EXPECT_TRUE(sky.obstacles.empty());
  const ob::ObstacleResult combined = d.combine({wall, sky});
  EXPECT_FALSE(combined.ok());
  EXPECT_TRUE(combined.obstacles.empty());
}

TEST(ObstacleDetector, BothPairsSeeingOneObstacleGiveOne) {
  const ob::ObstacleDetector d = synthetic_detector();
  ob::PairObstacles visible =
      d.from_disparity(ob::PairBand::visible, synthetic_disparity(d, {{10.0, -0.5, 0.5, 1.0}}));
  ASSERT_EQ(visible.obstacles.size(), 1u);
  ob::PairObstacles infrared = visible;  // the same obstacle, as the other pair measured it
  infrared.band = ob::PairBand::infrared;
  infrared.obstacles[0].bands = ob::kInfraredBit;
  infrared.obstacles[0].distance_m += 0.1;
  const ob::ObstacleResult r = d.combine({visible, infrared});
  ASSERT_EQ(r.obstacles.size(), 1u);
  EXPECT_EQ(r.obstacles[0].bands, ob::kVisibleBit | ob::kInfraredBit);
  EXPECT_NEAR(r.obstacles[0].distance_m, visible.obstacles[0].distance_m + 0.05, 1e-6);
  EXPECT_LT(r.obstacles[0].sigma_m, visible.obstacles[0].sigma_m);
}

TEST(ObstacleDetector, APairWithoutGroundTakesTheOthersWhenAskedTo) {
  // Two pairs on one grid; the infrared sees only the box (no texture on its road).
  const cam::RectifiedIntrinsics g = synthetic_grid();
  const rg::RangingGeometry pair{cam::RectifiedCamera(g), kBaseline, Eigen::Isometry3d::Identity()};
  for (const bool share : {false, true}) {
    ob::ObstacleOptions options;
    options.share_ground = share;
    const ob::ObstacleDetector d(g, {{ob::PairBand::visible, pair}, {ob::PairBand::infrared, pair}},
                                 Eigen::Isometry3d::Identity(), ob::GroundPrior{kHeight, 0.0, 0.0},
                                 options);
    const Face box{9.0, -0.5, 0.5, 1.2};
    const cv::Mat visible = synthetic_disparity(d, {box});
    cv::Mat infrared = synthetic_disparity(d, {box});
    infrared.setTo(NAN, synthetic_disparity(d, {}) == infrared);  // only the box
    const ob::ObstacleResult r =
        d.from_disparities({{ob::PairBand::visible, visible}, {ob::PairBand::infrared, infrared}});
    ASSERT_EQ(r.pairs.size(), 2u);
    EXPECT_TRUE(r.pairs[0].ok());
    EXPECT_EQ(r.pairs[1].ok(), share) << r.pairs[1].ground.message;
    EXPECT_EQ(r.pairs[1].ground_from_other, share);
    ASSERT_EQ(r.obstacles.size(), 1u);
    EXPECT_EQ(r.obstacles[0].bands, share ? ob::kVisibleBit | ob::kInfraredBit : ob::kVisibleBit);
    EXPECT_NEAR(r.obstacles[0].distance_m, 9.0, 0.2);
  }
}

TEST(ObstacleDetector, TracksTheGroundFromFrameToFrame) {
  // A road, the same road (searched about the first frame's ground), a wall filling the view
  // (no ground: the track is dropped), the road again (the prior's search).
  const ob::ObstacleDetector d = synthetic_detector();
  const cv::Mat road = synthetic_disparity(d, {{12.0, 0.5, 1.5, 0.8}});
  const cv::Mat wall = synthetic_disparity(d, {}, 3.0);
  ob::GroundTracks tracks;
  const ob::ObstacleResult untracked = d.from_disparities({{ob::PairBand::visible, road}});
  const std::vector<std::pair<cv::Mat, bool>> frames = {
      {road, false}, {road, true}, {wall, false}, {road, false}};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ob::ObstacleResult r =
        d.from_disparities({{ob::PairBand::visible, frames[i].first}}, tracks);
    ASSERT_EQ(r.pairs.size(), 1u);
    const ob::PairObstacles& p = r.pairs[0];
    const bool ground = frames[i].first.data == road.data;
    EXPECT_EQ(p.ok(), ground) << "frame " << i << ": " << p.ground.message;
    EXPECT_EQ(p.ground_tracked, frames[i].second) << "frame " << i;
    EXPECT_EQ(tracks.of(ob::PairBand::visible).tracking(), ground) << "frame " << i;
    if (!ground) continue;
    EXPECT_NEAR(p.ground.plane.height_m, untracked.pairs[0].ground.plane.height_m, 1e-3);
    ASSERT_EQ(r.obstacles.size(), 1u) << "frame " << i;
    EXPECT_NEAR(r.obstacles[0].distance_m, untracked.obstacles[0].distance_m, 0.05);
  }
  tracks.reset();
  EXPECT_FALSE(tracks.of(ob::PairBand::visible).tracking());
}

TEST(ObstacleDetector, InfraredCountsAreMatchedWithTheirOwnTextureFactor) {
  // Counts are matched as their stretched detail, whose noise estimate is a share of it.
  ob::ObstacleOptions options;
  options.dense.texture_noise_factor = 2.5;
  options.counts_texture_noise_factor = 1.5;
  const ob::ObstacleDetector d = synthetic_detector(options);
  EXPECT_EQ(d.dense_options_for(cv::Mat(4, 4, CV_16UC1)).texture_noise_factor, 1.5);
  EXPECT_EQ(d.dense_options_for(cv::Mat(4, 4, CV_8UC1)).texture_noise_factor, 2.5);
  EXPECT_EQ(d.dense_options_for(cv::Mat(4, 4, CV_8UC3)).texture_noise_factor, 2.5);
}

TEST(ObstacleDetector, BadInputIsNamed) {
  const ob::ObstacleDetector d = synthetic_detector();
  EXPECT_THROW(d.from_disparity(ob::PairBand::visible, cv::Mat(10, 10, CV_32F)),
               std::invalid_argument);
  EXPECT_THROW(d.from_disparity(ob::PairBand::infrared, synthetic_disparity(d, {})),
               std::invalid_argument);  // not set up
  const cv::Mat wrong(100, 100, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(d.detect_pair(ob::PairBand::visible, wrong, wrong), std::invalid_argument);
  ob::ObstacleOptions zero;
  zero.reduction = 0;
  EXPECT_THROW(synthetic_detector(zero), std::invalid_argument);
}

TEST(DenseDisparity, FindsAShiftedTexture) {
  cv::Mat noise(120, 200, CV_32F);
  cv::RNG rng(3);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.0);
  cv::Mat left, right;
  noise.convertTo(left, CV_8U);
  // The right eye sees every point 6.5 px further left.
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -6.5, 0, 1, 0);
  cv::warpAffine(noise, right, shift, noise.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  right.convertTo(right, CV_8U);
  for (ob::DenseMethod method : {ob::DenseMethod::block_matching, ob::DenseMethod::semi_global}) {
    ob::DenseOptions options;
    options.method = method;
    const cv::Mat d = ob::dense_disparity(left, right, 20, options);
    std::vector<float> valid;
    for (int y = 10; y < d.rows - 10; ++y)
      for (int x = 40; x < d.cols - 10; ++x)
        if (std::isfinite(d.at<float>(y, x))) valid.push_back(d.at<float>(y, x));
    ASSERT_GT(valid.size(), 5000u) << ob::method_name(method);
    std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
    EXPECT_NEAR(valid[valid.size() / 2], 6.5, 0.2) << ob::method_name(method);
  }
  EXPECT_THROW(ob::dense_disparity(left, right(cv::Rect(0, 0, 100, 100)), 20),
               std::invalid_argument);
  EXPECT_THROW(ob::dense_disparity(cv::Mat(10, 10, CV_16UC1), right, 20), std::invalid_argument);
  EXPECT_THROW(ob::parse_dense_method("surf"), std::invalid_argument);
}

namespace {

// Capture 0 of a shipped scene (seed 1) through `pipeline`'s rectification, with its targets.
struct SimulatedCapture {
  thermovis::sim::Scene scene;
  thermovis::pipeline::GridCapture capture;
  std::vector<thermovis::sim::TargetTruth> truths;
};
SimulatedCapture simulated_capture(const std::string& scene_name,
                                   thermovis::pipeline::CapturePipeline& pipeline) {
  namespace sim = thermovis::sim;
  SimulatedCapture out;
  out.scene = thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path(scene_name));
  const sim::SimulatedRig simulated(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()), out.scene, 1);
  sim::FrameSet frames = simulated.allocate();
  simulated.render(0, frames);
  out.capture =
      pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                        frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
  out.truths = simulated.truth(0);
  return out;
}

// The horizontal distance of a target's nearest surface point (the reporting camera's frame).
double nearest_m(const thermovis::sim::TargetTruth& t) {
  double nearest = 1e9;
  for (const Eigen::Vector3d& p : t.surface_points_m)
    nearest = std::min(nearest, std::hypot(p.x(), p.z()));
  return nearest;
}

// Of the obstacles overlapping `box`, the one whose distance is nearest `distance_m`.
const ob::Obstacle* obstacle_over(const std::vector<ob::Obstacle>& obstacles, const cv::Rect& box,
                                  double distance_m) {
  const ob::Obstacle* found = nullptr;
  for (const ob::Obstacle& o : obstacles) {
    if ((o.box & box).area() > 0 &&
        (found == nullptr ||
         std::abs(o.distance_m - distance_m) < std::abs(found->distance_m - distance_m))) {
      found = &o;
    }
  }
  return found;
}

}  // namespace

// The simulated street (frame 0) through the pipeline's rectification: the visible pair finds
// the ground at the rig's height and the standing person (15 m) and the near pole (10 m) as
// obstacles at their distances; the empty road (no targets, no walls) gives none there.
TEST(ObstacleDetectorOnSimulatedStreet, FindsTheGroundThePersonAndThePole) {
  namespace pl = thermovis::pipeline;
  pl::CapturePipeline pipeline(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()));
  const SimulatedCapture s = simulated_capture("street", pipeline);
  const pl::PipelineGeometry& g = pipeline.geometry();
  const ob::ObstacleDetector d(g.grid, {{ob::PairBand::visible, g.ranging(pl::Band::visible)}},
                               g.T_ref_reporting,
                               ob::GroundPrior{s.scene.camera_height_m, 0.0, 0.0});
  const pl::GridCapture& c = s.capture;
  const ob::PairObstacles r = d.detect_pair(ob::PairBand::visible, c.grey_left, c.grey_right);
  ASSERT_TRUE(r.ok()) << r.ground.message;
  EXPECT_NEAR(r.ground.plane.height_m, s.scene.camera_height_m, 0.05);
  for (const thermovis::sim::TargetTruth& t : s.truths) {
    if (t.id != "standing" && t.id != "pole_a") continue;
    const cv::Rect truth_box = pl::points_box_on_grid(g, pl::Band::visible, t.surface_points_m);
    const double nearest = nearest_m(t);
    const ob::Obstacle* found = obstacle_over(r.obstacles, truth_box, nearest);
    ASSERT_NE(found, nullptr) << t.id << " at " << nearest << " m, box " << truth_box;
    EXPECT_NEAR(found->distance_m, nearest, 0.06 * nearest) << t.id;
  }
}

TEST(DenseDisparity, TheNoiseOfAnImageIsMeasured) {
  // Flat grey with white noise of sigma 3, and the same on a ramp (planar intensity cancels).
  cv::Mat noise(200, 300, CV_32F);
  cv::RNG rng(5);
  rng.fill(noise, cv::RNG::NORMAL, 0, 3);
  cv::Mat ramp(noise.size(), CV_32F);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<float>(y, x) = 60.0f + 0.3f * x + 0.2f * y;
  cv::Mat flat8, ramp8;
  cv::Mat(noise + 128).convertTo(flat8, CV_8U);
  cv::Mat(noise + ramp).convertTo(ramp8, CV_8U);
  EXPECT_NEAR(ob::image_noise_sigma(flat8), 3.0, 0.3);
  EXPECT_NEAR(ob::image_noise_sigma(ramp8), 3.0, 0.3);
  // The block threshold follows the noise; without the factor it is the fixed one.
  ob::DenseOptions options;
  const int threshold = ob::block_texture_threshold(flat8, options);
  EXPECT_NEAR(threshold, options.texture_noise_factor * 49 * std::sqrt(24 / M_PI) * 3.0,
              0.12 * threshold);
  options.texture_noise_factor = 0;
  EXPECT_EQ(ob::block_texture_threshold(flat8, options), options.texture_threshold);
  EXPECT_THROW(ob::image_noise_sigma(cv::Mat(10, 10, CV_16UC1)), std::invalid_argument);
}

TEST(DenseDisparity, AFeaturelessSurfaceGivesNoDisparityInItsNoise) {
  // Both eyes see one flat grey surface with its own sensor noise (sigma 1.5) and a textured
  // band, shifted by 6 px, across the middle: disparities on the band only.
  cv::Mat texture(120, 220, CV_32F), left_noise(texture.size(), CV_32F),
      right_noise(texture.size(), CV_32F);
  cv::RNG rng(9);
  rng.fill(texture, cv::RNG::UNIFORM, -40, 40);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.0);
  rng.fill(left_noise, cv::RNG::NORMAL, 0, 1.5);
  rng.fill(right_noise, cv::RNG::NORMAL, 0, 1.5);
  const cv::Rect band(0, 50, 220, 20);
  cv::Mat left_f(texture.size(), CV_32F, cv::Scalar(100)), right_f = left_f.clone();
  left_f(band) += texture(band);
  cv::Mat shifted;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -6, 0, 1, 0);
  cv::warpAffine(texture, shifted, shift, texture.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  right_f(band) += shifted(band);
  cv::Mat left, right;
  cv::Mat(left_f + left_noise).convertTo(left, CV_8U);
  cv::Mat(right_f + right_noise).convertTo(right, CV_8U);
  auto off_band = [&](const cv::Mat& d) {
    int n = 0;
    for (int y = 0; y < d.rows; ++y)
      for (int x = 40; x < d.cols; ++x)
        if (std::abs(y - 60) > 15 && std::isfinite(d.at<float>(y, x))) ++n;
    return n;
  };
  auto on_band = [&](const cv::Mat& d) {
    int n = 0;
    for (int y = 55; y < 65; ++y)
      for (int x = 40; x < d.cols - 10; ++x)
        if (std::abs(d.at<float>(y, x) - 6.0f) < 0.5f) ++n;
    return n;
  };
  ob::DenseOptions options;
  const cv::Mat d = ob::dense_disparity(left, right, 20, options);
  EXPECT_EQ(off_band(d), 0);
  // The blocks with texture: those over the band (its 20 rows and a few of the 6 rows that
  // reach into it, of 114 block rows), no others.
  const double textured = ob::textured_share(left, options);
  EXPECT_GT(textured, 14.0 / 114.0);
  EXPECT_LT(textured, 26.0 / 114.0);
  EXPECT_LT(ob::textured_share(left(cv::Rect(0, 0, 220, 40)), options), 0.01);
  EXPECT_GT(on_band(d), 0.8 * 10 * 170);
  options.texture_noise_factor = 0;  // the fixed threshold alone: matches in the noise
  EXPECT_GT(off_band(ob::dense_disparity(left, right, 20, options)), 20);
}

// The simulated street without its targets and walls (a textured road, its verges, the dashed
// centre line, the horizon): no obstacle in a few frames, the ground found in each.
TEST(ObstacleDetectorOnSimulatedStreet, AnEmptyRoadGivesNoObstacle) {
  namespace pl = thermovis::pipeline;
  namespace sim = thermovis::sim;
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  sim::Scene scene =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("street"));
  scene.targets.clear();
  scene.walls.clear();
  const sim::SimulatedRig simulated(rig, scene, 2);
  pl::CapturePipeline pipeline(rig);
  const pl::PipelineGeometry& g = pipeline.geometry();
  const ob::ObstacleDetector d(g.grid, {{ob::PairBand::visible, g.ranging(pl::Band::visible)}},
                               g.T_ref_reporting, ob::GroundPrior{scene.camera_height_m, 0.0, 0.0});
  sim::FrameSet frames = simulated.allocate();
  for (std::int64_t frame = 0; frame < 6; ++frame) {
    simulated.render(frame, frames);
    const pl::GridCapture c =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    const ob::PairObstacles r = d.detect_pair(ob::PairBand::visible, c.grey_left, c.grey_right);
    ASSERT_TRUE(r.ok()) << "frame " << frame << ": " << r.ground.message;
    EXPECT_TRUE(r.obstacles.empty())
        << "frame " << frame << ": " << r.obstacles.size() << " obstacles, the first at "
        << r.obstacles.front().distance_m << " m, box " << r.obstacles.front().box;
  }
}

TEST(DenseDisparity, BadPixelsAgainstATruth) {
  // Four pixels with a truth: one exact, one 1.5 px off, one 3 px off, one without a disparity;
  // a fifth without a truth is not counted.
  const cv::Mat truth = (cv::Mat_<float>(1, 5) << 10, 10, 10, 10, INFINITY);
  const cv::Mat d = (cv::Mat_<float>(1, 5) << 10, 11.5, 13, NAN, 3);
  const ob::DenseAccuracy a = ob::evaluate_dense(d, truth);
  EXPECT_EQ(a.truth_pixels, 4);
  EXPECT_DOUBLE_EQ(a.valid, 0.75);
  EXPECT_DOUBLE_EQ(a.bad1, 0.75);
  EXPECT_DOUBLE_EQ(a.bad2, 0.5);
  EXPECT_DOUBLE_EQ(a.bad1_valid, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(a.bad2_valid, 1.0 / 3.0);
  EXPECT_THROW(ob::evaluate_dense(d, truth(cv::Rect(0, 0, 4, 1))), std::invalid_argument);
}

// The stixels' one-sort median and deviation give exactly the two selections' values (the
// detector's results do not move), on disparities in the matchers' 1/16 px steps with ties, and
// on arbitrary ones.
TEST(RobustStatistics, TheMedianAndDeviationAreTheTwoMediansValues) {
  std::mt19937 random(7);
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = 1 + trial % 61;
    const bool steps = trial % 2 == 0;
    std::uniform_real_distribution<double> value(10.0, 10.0 + (trial % 7 + 1) * 0.5);
    std::vector<double> v(static_cast<std::size_t>(n));
    for (double& x : v) x = steps ? std::round(value(random) * 16) / 16 : value(random);
    std::vector<double> a = v, b = v;
    const double median = ob::median_of(a);
    std::vector<double> deviations;
    for (double x : a) deviations.push_back(std::abs(x - median));
    const double deviation = ob::median_of(deviations);
    const auto [m, d] = ob::median_and_deviation(b);
    ASSERT_EQ(m, median) << "n " << n;
    ASSERT_EQ(d, deviation) << "n " << n;
  }
  std::vector<double> none;
  EXPECT_TRUE(std::isnan(ob::median_and_deviation(none).first));
}

namespace {

void expect_same(const ob::ObstacleResult& a, const ob::ObstacleResult& b, int frame) {
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (std::size_t i = 0; i < a.pairs.size(); ++i) {
    const ob::PairObstacles &p = a.pairs[i], &q = b.pairs[i];
    EXPECT_EQ(p.ground.status, q.ground.status) << "frame " << frame;
    EXPECT_EQ(p.ground.inlier_pixels, q.ground.inlier_pixels) << "frame " << frame;
    EXPECT_EQ(p.ground.plane.normal, q.ground.plane.normal) << "frame " << frame;
    ASSERT_EQ(p.stixels.size(), q.stixels.size()) << "frame " << frame;
    for (std::size_t k = 0; k < p.stixels.size(); ++k) {
      EXPECT_EQ(p.stixels[k].column, q.stixels[k].column);
      EXPECT_EQ(p.stixels[k].top_row, q.stixels[k].top_row);
      EXPECT_EQ(p.stixels[k].distance_m, q.stixels[k].distance_m);
      EXPECT_EQ(p.stixels[k].sigma_m, q.stixels[k].sigma_m);
    }
  }
  ASSERT_EQ(a.obstacles.size(), b.obstacles.size()) << "frame " << frame;
  for (std::size_t k = 0; k < a.obstacles.size(); ++k) {
    EXPECT_EQ(a.obstacles[k].box, b.obstacles[k].box) << "frame " << frame;
    EXPECT_EQ(a.obstacles[k].distance_m, b.obstacles[k].distance_m) << "frame " << frame;
  }
  ASSERT_EQ(a.free_space_m.size(), b.free_space_m.size());
  for (std::size_t x = 0; x < a.free_space_m.size(); ++x) {
    const float u = a.free_space_m[x], v = b.free_space_m[x];
    EXPECT_TRUE(u == v || (std::isnan(u) && std::isnan(v))) << "frame " << frame << " x " << x;
  }
}

}  // namespace

// The detector keeps its buffers from capture to capture (per thread): captures after others,
// one of them again, give what a thread that has seen none gives (no state leaks into the next
// capture), with both pairs and the share of the ground between them.
TEST(ObstacleDetectorOnSimulatedStreet, BuffersKeptFromTheLastCaptureChangeNothing) {
  namespace pl = thermovis::pipeline;
  namespace sim = thermovis::sim;
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  const sim::Scene scene =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("street"));
  const sim::SimulatedRig simulated(rig, scene, 1);
  pl::CapturePipeline pipeline(rig);
  const pl::PipelineGeometry& g = pipeline.geometry();
  ob::ObstacleOptions options;
  options.share_ground = true;
  const ob::ObstacleDetector d(g.grid,
                               {{ob::PairBand::visible, g.ranging(pl::Band::visible)},
                                {ob::PairBand::infrared, g.ranging(pl::Band::infrared)}},
                               g.T_ref_reporting, ob::GroundPrior{scene.camera_height_m, 0.0, 0.0},
                               options);
  sim::FrameSet frames = simulated.allocate();
  for (const std::int64_t frame : {0, 30, 0}) {
    simulated.render(frame, frames);
    const pl::GridCapture c =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    const ob::ObstacleResult kept =
        d.detect(c.grey_left, c.grey_right, c.infrared_left, c.infrared_right);
    ob::ObstacleResult fresh;
    std::thread([&] {
      fresh = d.detect(c.grey_left, c.grey_right, c.infrared_left, c.infrared_right);
    }).join();
    ASSERT_FALSE(kept.obstacles.empty());
    expect_same(kept, fresh, static_cast<int>(frame));
  }
}

// The noise estimate in one integer pass is the filter's (filter2D over the image, the mean of
// its magnitude inside the border) to the bit, on noise, a ramp and a simulated-like texture.
TEST(DenseDisparity, TheNoiseEstimateIsTheFiltersValue) {
  std::mt19937 random(3);
  for (const cv::Size size : {cv::Size(3, 3), cv::Size(17, 5), cv::Size(468, 138)}) {
    for (int kind = 0; kind < 3; ++kind) {
      cv::Mat grey(size, CV_8U);
      std::uniform_int_distribution<int> level(0, 255), small(-4, 4);
      for (int r = 0; r < grey.rows; ++r) {
        for (int c = 0; c < grey.cols; ++c) {
          const int v = kind == 0 ? level(random) : kind == 1 ? c + 2 * r + small(random) : 128;
          grey.at<std::uint8_t>(r, c) = cv::saturate_cast<std::uint8_t>(v);
        }
      }
      const cv::Mat kernel = (cv::Mat_<float>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
      cv::Mat response;
      cv::filter2D(grey, response, CV_32F, kernel);
      const cv::Rect inner(1, 1, grey.cols - 2, grey.rows - 2);
      const double reference =
          cv::mean(cv::abs(response(inner)))[0] / (6.0 * std::sqrt(2.0 / M_PI));
      EXPECT_EQ(ob::image_noise_sigma(grey), reference) << size << " kind " << kind;
    }
  }
}

namespace {

// Of the obstacles the visible pair finds with `options` in a simulated capture, the one over a
// target's box nearest its nearest point's distance (none: empty), and that distance.
struct ObstacleOverTarget {
  std::optional<ob::Obstacle> obstacle;
  double nearest_m = 0;
  bool ground_ok = false;
  std::string ground_message;
  // Found within this share of the target's distance.
  bool within(double share) const {
    return obstacle && std::abs(obstacle->distance_m - nearest_m) <= share * nearest_m;
  }
};

ObstacleOverTarget obstacle_over_target(const SimulatedCapture& s,
                                        const thermovis::pipeline::CapturePipeline& pipeline,
                                        const std::string& id, const ob::ObstacleOptions& options) {
  namespace pl = thermovis::pipeline;
  const pl::PipelineGeometry& g = pipeline.geometry();
  const auto target =
      std::find_if(s.truths.begin(), s.truths.end(),
                   [&](const thermovis::sim::TargetTruth& t) { return t.id == id; });
  EXPECT_NE(target, s.truths.end()) << id;
  ObstacleOverTarget out;
  if (target == s.truths.end()) return out;
  const cv::Rect truth_box = pl::points_box_on_grid(g, pl::Band::visible, target->surface_points_m);
  out.nearest_m = nearest_m(*target);
  const ob::ObstacleDetector d(g.grid, {{ob::PairBand::visible, g.ranging(pl::Band::visible)}},
                               g.T_ref_reporting,
                               ob::GroundPrior{s.scene.camera_height_m, 0.0, 0.0}, options);
  const ob::PairObstacles found =
      d.detect_pair(ob::PairBand::visible, s.capture.grey_left, s.capture.grey_right);
  out.ground_ok = found.ok();
  out.ground_message = found.ground.message;
  if (const ob::Obstacle* o = obstacle_over(found.obstacles, truth_box, out.nearest_m)) {
    out.obstacle = *o;
  }
  return out;
}

}  // namespace

// The shipped obstacles scene (frame 0, visible pair): the pole at 18 m is 0.2 m wide, about
// one reduced column, so every block of the stixels' disparity mixes it with the road and hedge
// beside it (7 % short in `thermovis bench obstacles --scene obstacles`). Its near face aligned
// as one region at the grid's resolution (ObstacleOptions::refine) ranges it within 3 %.
TEST(ObstacleDetectorOnSimulatedObstacles, ANarrowObstacleIsRangedOnTheGridsOwnPixels) {
  thermovis::pipeline::CapturePipeline pipeline(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()));
  const SimulatedCapture s = simulated_capture("obstacles", pipeline);
  // The obstacle over the pole's box nearest its distance, with and without the refinement.
  double nearest = 0;
  auto ranged = [&](bool refine) {
    ob::ObstacleOptions options;
    options.refine = refine;
    const ObstacleOverTarget a = obstacle_over_target(s, pipeline, "pole_18", options);
    nearest = a.nearest_m;
    return a.obstacle ? a.obstacle->distance_m : std::numeric_limits<double>::quiet_NaN();
  };
  const double refined = ranged(true), stixels = ranged(false);
  ASSERT_TRUE(std::isfinite(refined)) << "no obstacle over the pole's box";
  ASSERT_TRUE(std::isfinite(stixels));
  EXPECT_NEAR(refined, nearest, 0.03 * nearest) << "stixels alone: " << stixels;
  EXPECT_LT(std::abs(refined - nearest), std::abs(stixels - nearest));
}

// The obstacles scene's 0.5 m box at 20 m is 5 reduced rows tall, of which only the top 0.14 m
// stand above min_height_m + 3 sigma of one pixel's height noise: no stixel of pixels that stand
// one by one. Its run of rows at one disparity stands as a whole (ObstacleOptions::
// vertical_max_share: the ground would gain 2 px of disparity over it, it gains none). On the
// reduced grid alone (the far band, which finds it on the grid's own pixels, off).
TEST(ObstacleDetectorOnSimulatedObstacles, AShortBoxStandsAsAWholeRun) {
  thermovis::pipeline::CapturePipeline pipeline(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()));
  const SimulatedCapture s = simulated_capture("obstacles", pipeline);
  ob::ObstacleOptions with, without;
  with.far_band = without.far_band = false;
  without.vertical_max_share = 0;
  const ObstacleOverTarget a = obstacle_over_target(s, pipeline, "box_20", with);
  ASSERT_TRUE(a.ground_ok) << a.ground_message;
  ASSERT_TRUE(a.within(0.1)) << "no obstacle over the box at " << a.nearest_m << " m";
  EXPECT_NEAR(a.obstacle->distance_m, a.nearest_m, 0.04 * a.nearest_m);
  EXPECT_LT(a.obstacle->extent_m.y(), 1.0) << "the box is 0.5 m tall";
  EXPECT_FALSE(obstacle_over_target(s, pipeline, "box_20", without).within(0.1))
      << "found without the run test: this test no longer shows it";
}

// The boxes at 30 and 40 m are 3.5 and 2.6 reduced rows tall, under the matcher's 7-row block:
// the reduced grid finds neither. The far band (ObstacleOptions::far_band: the visible pair
// matched again on the grid's own pixels about the horizon) finds both within 5 %.
TEST(ObstacleDetectorOnSimulatedObstacles, FarShortBoxesAreFoundInTheFarBand) {
  thermovis::pipeline::CapturePipeline pipeline(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()));
  const SimulatedCapture s = simulated_capture("obstacles", pipeline);
  ob::ObstacleOptions reduced_only;
  reduced_only.far_band = false;
  for (const std::string id : {"box_30", "box_40"}) {
    const ObstacleOverTarget a = obstacle_over_target(s, pipeline, id, {});
    ASSERT_TRUE(a.within(0.1)) << "no obstacle over " << id << " at " << a.nearest_m << " m";
    EXPECT_NEAR(a.obstacle->distance_m, a.nearest_m, 0.05 * a.nearest_m) << id;
    EXPECT_FALSE(obstacle_over_target(s, pipeline, id, reduced_only).within(0.1))
        << id << " found on the reduced grid alone: this test no longer shows the far band";
  }
}

namespace {

// Capture 0 of the shipped street scene on the pipeline grid.
thermovis::pipeline::GridCapture street_capture() {
  thermovis::pipeline::CapturePipeline pipeline(
      thermovis::runtime::load_rig(thermovis::runtime::default_rig_path()));
  return simulated_capture("street", pipeline).capture;
}

}  // namespace

namespace {

// Infrared counts to grey (grey_pair) as it was written with OpenCV calls: float images, a 9 x 9
// cv::blur, the detail's robust spread from every other pixel, the stretch (lowered where the
// noise is more than kMaxCountsNoiseGrey), the flat border.
// The one-pass detail must give the same grey images to the bit.
void reference_grey_counts(const cv::Mat& left, const cv::Mat& right, cv::Mat& left8,
                           cv::Mat& right8) {
  cv::Mat lf, rf, lb, rb;
  left.convertTo(lf, CV_32F);
  right.convertTo(rf, CV_32F);
  cv::blur(lf, lb, cv::Size(9, 9));
  cv::blur(rf, rb, cv::Size(9, 9));
  lf -= lb;
  rf -= rb;
  std::vector<float> detail;
  for (int r = 0; r < left.rows; r += 2) {
    for (int c = 0; c < left.cols; c += 2) {
      if (left.at<std::uint16_t>(r, c) != 0) detail.push_back(std::abs(lf.at<float>(r, c)));
    }
  }
  float spread = 1.0f;
  if (!detail.empty()) {
    const auto mid = detail.begin() + static_cast<std::ptrdiff_t>(detail.size() / 2);
    std::nth_element(detail.begin(), mid, detail.end());
    spread = std::max(1.4826f * *mid, 1e-3f);
  }
  double gain = 64.0 / (3.0 * spread);
  lf.convertTo(left8, CV_8U, gain, 128.0);
  left8.setTo(128, left == 0);
  const double noise = ob::image_noise_sigma(left8);
  if (noise > ob::kMaxCountsNoiseGrey) {
    gain *= ob::kMaxCountsNoiseGrey / noise;
    lf.convertTo(left8, CV_8U, gain, 128.0);
    left8.setTo(128, left == 0);
  }
  rf.convertTo(right8, CV_8U, gain, 128.0);
  right8.setTo(128, right == 0);
}

}  // namespace

TEST(DenseDisparity, InfraredCountsToGreyAreTheReferencesToTheBit) {
  std::mt19937 random(11);
  std::vector<std::pair<cv::Mat, cv::Mat>> pairs;
  for (const cv::Size size : {cv::Size(16, 16), cv::Size(23, 9), cv::Size(468, 134)}) {
    cv::Mat l(size, CV_16U), r(size, CV_16U);
    std::uniform_int_distribution<int> counts(7000, 7400), wide(0, 65535);
    for (int y = 0; y < size.height; ++y) {
      for (int x = 0; x < size.width; ++x) {
        l.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(x < 3 ? 0 : counts(random));
        r.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(y % 5 == 0 ? wide(random) : 7200);
      }
    }
    pairs.emplace_back(l, r);
  }
  const thermovis::pipeline::GridCapture c = street_capture();
  ASSERT_EQ(c.infrared_left.type(), CV_16UC1);
  pairs.emplace_back(c.infrared_left, c.infrared_right);
  for (const auto& [l, r] : pairs) {
    cv::Mat l8, r8, want_l8, want_r8;
    ob::grey_pair(l, r, l8, r8);
    reference_grey_counts(l, r, want_l8, want_r8);
    EXPECT_EQ(cv::norm(l8, want_l8, cv::NORM_INF), 0) << l.size();
    EXPECT_EQ(cv::norm(r8, want_r8, cv::NORM_INF), 0) << l.size();
  }
}

namespace {

// textured_share as it was written with OpenCV calls (Sobel, abs, min, a box filter, a count).
double reference_textured_share(const cv::Mat& left, const ob::DenseOptions& options) {
  const int b = options.block_size;
  cv::Mat sobel, magnitude, texture;
  cv::Sobel(left, sobel, CV_16S, 1, 0, 3);
  cv::min(cv::abs(sobel), 31, magnitude);
  magnitude.convertTo(magnitude, CV_32S);
  cv::boxFilter(magnitude, texture, CV_32S, cv::Size(b, b), cv::Point(-1, -1), false,
                cv::BORDER_REPLICATE);
  const int threshold = ob::block_texture_threshold(left, options);
  const cv::Rect inner(b / 2, b / 2, left.cols - b + 1, left.rows - b + 1);
  return static_cast<double>(cv::countNonZero(texture(inner) >= threshold)) / inner.area();
}

}  // namespace

// The textured share in one integer pass is the OpenCV calls' to the bit: random and smooth
// images, block sizes, fixed and noise-relative thresholds, the simulated visible image.
TEST(DenseDisparity, TheTexturedShareIsTheReferencesToTheBit) {
  std::mt19937 random(5);
  std::vector<cv::Mat> images;
  for (const cv::Size size : {cv::Size(5, 5), cv::Size(31, 12), cv::Size(468, 138)}) {
    for (int kind = 0; kind < 2; ++kind) {
      cv::Mat grey(size, CV_8U);
      std::uniform_int_distribution<int> level(0, 255), small(-3, 3);
      for (int r = 0; r < grey.rows; ++r) {
        for (int c = 0; c < grey.cols; ++c) {
          const int v = kind == 0 ? level(random) : 100 + c / 3 + small(random);
          grey.at<std::uint8_t>(r, c) = cv::saturate_cast<std::uint8_t>(v);
        }
      }
      images.push_back(grey);
    }
  }
  const thermovis::pipeline::GridCapture c = street_capture();
  images.push_back(c.grey_left);
  for (const cv::Mat& image : images) {
    for (const int block : {5, 7, 9}) {
      for (const double factor : {0.0, 1.5, 2.5}) {
        ob::DenseOptions options;
        options.block_size = block;
        options.texture_noise_factor = factor;
        if (image.rows < block || image.cols < block) continue;
        EXPECT_EQ(ob::textured_share(image, options), reference_textured_share(image, options))
            << image.size() << " block " << block << " factor " << factor;
      }
    }
  }
}
