// The ground's plane and its fit on exact synthetic points: the prior's frames, a road seen
// level and pitched, and the views without a ground.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "thermovis/obstacle/ground.hpp"

namespace ob = thermovis::obstacle;

namespace {

// An equirectangular grid's points (rows at beta = (row - cy) / f, columns at alpha) where the
// rays meet the plane n . p = h, NaN where they miss it (sky) or beyond 80 m.
struct Grid {
  int width = 200, height = 90;
  double f = 100, cx = 99.5, cy = -10;  // the rows from just above the horizon down
  std::vector<double> row_beta() const {
    std::vector<double> b;
    for (int r = 0; r < height; ++r) b.push_back((r - cy) / f);
    return b;
  }
  Eigen::Vector3d ray(int c, int r) const {
    const double a = (c - cx) / f, b = (r - cy) / f;
    return {std::sin(a), std::cos(a) * std::sin(b), std::cos(a) * std::cos(b)};
  }
  cv::Mat points_on(const ob::GroundPlane& plane) const {
    cv::Mat p(height, width, CV_32FC3, cv::Scalar::all(NAN));
    for (int r = 0; r < height; ++r)
      for (int c = 0; c < width; ++c) {
        const Eigen::Vector3d u = ray(c, r);
        const double down = plane.normal.dot(u);
        if (!(down > 0)) continue;
        const double B = plane.height_m / down;
        if (B > 80) continue;
        const Eigen::Vector3d P = B * u;
        p.at<cv::Vec3f>(r, c) = cv::Vec3f(P.x(), P.y(), P.z());
      }
    return p;
  }
};

constexpr double kFBaseline = 100 * 0.3;  // f A, px m

}  // namespace

TEST(GroundPlane, PriorAndFrames) {
  ob::GroundPrior prior;
  prior.camera_height_m = 1.5;
  prior.pitch_rad = 0.05;
  prior.roll_rad = -0.02;
  const ob::GroundPlane rig = ob::prior_plane(prior);
  EXPECT_NEAR(rig.normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(ob::pitch_of(rig), 0.05, 1e-12);
  EXPECT_NEAR(ob::roll_of(rig), -0.02, 1e-12);
  // A frame 0.06 m lower (y down) is 0.06 m nearer the ground; a point on the ground stays on it.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(0.1, 0.06, 0.0);
  T.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const ob::GroundPlane moved = ob::plane_in_frame(rig, T);
  const Eigen::Vector3d on_ground_rig =
      rig.height_m * rig.normal + Eigen::Vector3d(3, 0, 0).cross(rig.normal);
  EXPECT_NEAR(rig.height_of(on_ground_rig), 0.0, 1e-12);
  EXPECT_NEAR(moved.height_of(T.inverse() * on_ground_rig), 0.0, 1e-12);
  EXPECT_LT(moved.height_m, rig.height_m);
  EXPECT_THROW(ob::prior_plane({0.0, 0.0, 0.0}), std::invalid_argument);
  EXPECT_THROW(ob::prior_plane({1.4, NAN, 0.0}), std::invalid_argument);
}

TEST(FitGround, FindsALevelRoad) {
  const Grid g;
  const ob::GroundPlane truth = ob::prior_plane({1.4, 0.0, 0.0});
  const ob::GroundFit fit = ob::fit_ground(g.points_on(truth), g.row_beta(), kFBaseline, truth);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_NEAR(fit.plane.height_m, 1.4, 1e-3);
  EXPECT_NEAR((fit.plane.normal - truth.normal).norm(), 0.0, 1e-3);
  EXPECT_GT(fit.rows_with_ground, fit.rows_searched / 2);
}

TEST(FitGround, FindsThePitchAndHeightTheVehicleMovesTo) {
  // The rig pitched 2.5 deg down and 8 % lower than its prior; a roll of 1 deg besides (the
  // tan(alpha) term the least squares takes).
  const Grid g;
  const ob::GroundPlane prior = ob::prior_plane({1.4, 0.0, 0.0});
  const ob::GroundPlane truth = ob::prior_plane({1.29, 0.0436, 0.0175});
  const ob::GroundFit fit = ob::fit_ground(g.points_on(truth), g.row_beta(), kFBaseline, prior);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_NEAR(fit.plane.height_m, 1.29, 0.01);
  EXPECT_NEAR(ob::pitch_of(fit.plane), 0.0436, 0.002);
  EXPECT_NEAR(ob::roll_of(fit.plane), 0.0175, 0.002);
}

TEST(FitGround, NoDisparityIsSaid) {
  const Grid g;
  const cv::Mat sky(g.height, g.width, CV_32FC3, cv::Scalar::all(NAN));
  const ob::GroundPlane prior = ob::prior_plane({1.4, 0.0, 0.0});
  const ob::GroundFit fit = ob::fit_ground(sky, g.row_beta(), kFBaseline, prior);
  EXPECT_EQ(fit.status, ob::GroundStatus::no_disparity);
  EXPECT_NE(fit.message.find("disparities on 0"), std::string::npos) << fit.message;
}

TEST(FitGround, AWallFillingTheViewIsNoGround) {
  // A wall across the view 4 m ahead: a plane z = 4 (normal along z) everywhere.
  const Grid g;
  ob::GroundPlane wall;
  wall.normal = Eigen::Vector3d::UnitZ();
  wall.height_m = 4.0;
  const ob::GroundFit fit =
      ob::fit_ground(g.points_on(wall), g.row_beta(), kFBaseline, ob::prior_plane({1.4, 0, 0}));
  EXPECT_EQ(fit.status, ob::GroundStatus::no_ground) << fit.message;
}

TEST(FitGround, ATiltedRigIsNoGround) {
  // Rolled 15 deg, or pitched 10 deg: beyond the prior's search.
  const Grid g;
  const ob::GroundPlane prior = ob::prior_plane({1.4, 0.0, 0.0});
  for (const ob::GroundPrior tilted :
       {ob::GroundPrior{1.4, 0.0, 0.26}, ob::GroundPrior{1.4, 0.17, 0.0}}) {
    const ob::GroundFit fit =
        ob::fit_ground(g.points_on(ob::prior_plane(tilted)), g.row_beta(), kFBaseline, prior);
    EXPECT_EQ(fit.status, ob::GroundStatus::no_ground)
        << "pitch " << tilted.pitch_rad << " roll " << tilted.roll_rad << ": " << fit.message;
  }
}

TEST(FitGround, BadInputIsNamed) {
  const Grid g;
  const ob::GroundPlane prior = ob::prior_plane({1.4, 0.0, 0.0});
  EXPECT_THROW(
      ob::fit_ground(cv::Mat(g.height, g.width, CV_32FC1), g.row_beta(), kFBaseline, prior),
      std::invalid_argument);
  EXPECT_THROW(ob::fit_ground(g.points_on(prior), {0.1, 0.2}, kFBaseline, prior),
               std::invalid_argument);
}

TEST(GroundTracker, SearchesAboutTheLastGroundAndFallsBackToThePrior) {
  const Grid g;
  const ob::GroundPlane prior = ob::prior_plane({1.4, 0.0, 0.0});
  const ob::GroundOptions options;
  ob::GroundTracker tracker;
  EXPECT_FALSE(tracker.tracking());
  EXPECT_EQ(&tracker.centre(prior), &prior);
  EXPECT_EQ(tracker.search_options(options).max_pitch_change_rad, options.max_pitch_change_rad);
  // The vehicle pitched 2.5 deg down: found about the prior, then searched about it, narrower.
  const ob::GroundPlane pitched = ob::prior_plane({1.35, 0.0436, 0.0});
  ob::GroundFit fit = ob::fit_ground(g.points_on(pitched), g.row_beta(), kFBaseline, prior);
  ASSERT_TRUE(fit.ok()) << fit.message;
  tracker.update(fit);
  ASSERT_TRUE(tracker.tracking());
  EXPECT_NEAR(ob::pitch_of(tracker.centre(prior)), 0.0436, 0.002);
  const ob::GroundOptions narrow = tracker.search_options(options);
  EXPECT_EQ(narrow.max_pitch_change_rad, tracker.options().max_pitch_change_rad);
  EXPECT_EQ(narrow.max_height_factor, tracker.options().max_height_factor);
  // Another degree down: within the narrow search.
  const ob::GroundPlane further = ob::prior_plane({1.35, 0.0611, 0.0});
  fit =
      ob::fit_ground(g.points_on(further), g.row_beta(), kFBaseline, tracker.centre(prior), narrow);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_NEAR(ob::pitch_of(fit.plane), 0.0611, 0.002);
  EXPECT_NEAR(fit.plane.height_m, 1.35, 0.01);
  tracker.update(fit);
  // 4 deg from the last ground is beyond the narrow search (the prior's would take it).
  const ob::GroundPlane jumped = ob::prior_plane({1.35, 0.0611 - 0.07, 0.0});
  EXPECT_FALSE(ob::fit_ground(g.points_on(jumped), g.row_beta(), kFBaseline, tracker.centre(prior),
                              tracker.search_options(options))
                   .ok());
  EXPECT_TRUE(ob::within_search(fit.plane, prior, options));
  // A frame without ground: the prior's search again.
  ob::GroundPlane wall;
  wall.normal = Eigen::Vector3d::UnitZ();
  wall.height_m = 4.0;
  tracker.update(ob::fit_ground(g.points_on(wall), g.row_beta(), kFBaseline, prior));
  EXPECT_FALSE(tracker.tracking());
  EXPECT_EQ(tracker.search_options(options).max_height_factor, options.max_height_factor);
  EXPECT_THROW(ob::GroundTracker({0.0, 1.05}), std::invalid_argument);
  EXPECT_THROW(ob::GroundTracker({0.02, 1.0}), std::invalid_argument);
}
