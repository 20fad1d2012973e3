// The simulated rig renders through the real camera models: targets land where the models
// project them, stereo disparities match the true distances, noise is deterministic per seed and
// has the stated size, and the night scene is dark in the visible band only.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "rendered.hpp"
#include "thermovis/rectify/stereo_geometry.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

using thermovis::sim::FrameSet;
using thermovis::sim::RenderOptions;
using thermovis::sim::SimulatedRig;
using thermovis::sim::Slot;
using thermovis::sim::TargetTruth;

thermovis::camera::Rig paper_rig() {
  return thermovis::runtime::load_rig(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
}

thermovis::sim::Scene shipped(const std::string& name) {
  return thermovis::runtime::load_scene(thermovis::test::source_root() / "deploy/scenes" /
                                        (name + ".yaml"));
}

const TargetTruth& find(const std::vector<TargetTruth>& truth, const std::string& id) {
  for (const auto& t : truth) {
    if (t.id == id) return t;
  }
  throw std::runtime_error("no target " + id);
}

// One channel of an image as doubles (visible: green; infrared: counts).
cv::Mat channel(const cv::Mat& image) {
  cv::Mat out;
  if (image.channels() == 3) {
    cv::extractChannel(image, out, 1);
  } else {
    out = image;
  }
  out.convertTo(out, CV_64F);
  return out;
}

cv::Rect box_rect(const thermovis::sim::TruthBox& b, int margin) {
  return cv::Rect(cv::Point(static_cast<int>(std::floor(b.x_min)) - margin,
                            static_cast<int>(std::floor(b.y_min)) - margin),
                  cv::Point(static_cast<int>(std::ceil(b.x_max)) + margin + 1,
                            static_cast<int>(std::ceil(b.y_max)) + margin + 1));
}

TEST(SimulatedRig, MarkersLandWhereEachCameraModelProjectsThem) {
  // Self-luminous spheres against a uniform dark sky, without noise: each pixel's coverage is
  // (value - sky) / (marker - sky), and the coverage centroid is the image of the sphere's
  // centre (to ~0.02 px for these sizes). One marker moves, so the per-frame path is covered.
  const auto scene = thermovis::runtime::parse_scene(R"(name: markers
visible: {sky_colour_rgb: [0.2, 0.2, 0.2]}
ground: {road_half_width_m: 0, centre_line: false}
targets:
  - {id: centre, class: marker, distance_m: 10, bearing_deg: 0, elevation_m: 2.5, width_m: 0.12}
  - {id: left, class: marker, distance_m: 8, bearing_deg: -45, elevation_m: 3.0, width_m: 0.12}
  - {id: right, class: marker, distance_m: 12, bearing_deg: 38, elevation_m: 5.0, width_m: 0.12}
  - {id: moving, class: marker, distance_m: 9, bearing_deg: 15, elevation_m: 2.0, width_m: 0.12,
     velocity_mps: [0.4, 0.3]}
)",
                                                     "markers");
  RenderOptions options;
  options.temporal_noise = false;
  options.fixed_pattern = false;
  const SimulatedRig sim(paper_rig(), scene, 3, options);
  FrameSet frames = sim.allocate();
  const std::int64_t frame = 25;  // the moving marker has moved (0.2, 0.15) m
  sim.render(frame, frames);
  const auto truth = sim.truth(frame);
  ASSERT_EQ(truth.size(), 4u);
  const Eigen::Isometry3d T_ref_visible_left = sim.rig().camera(sim.rig().visible.left).T_ref_cam;
  double worst_px = 0.0;
  for (const TargetTruth& t : truth) {
    const Eigen::Vector3d centre_ref = T_ref_visible_left * t.position_m;
    for (int i = 0; i < thermovis::sim::kSlotCount; ++i) {
      const Slot slot = static_cast<Slot>(i);
      SCOPED_TRACE(t.id + " in " + to_string(slot));
      const auto& cam = sim.camera(slot);
      Eigen::Vector2d expected;
      ASSERT_TRUE(cam.model->project(cam.T_ref_cam.inverse() * centre_ref, expected));
      ASSERT_TRUE(t.boxes[static_cast<std::size_t>(i)].has_value());
      const cv::Rect roi = box_rect(*t.boxes[static_cast<std::size_t>(i)], 3) &
                           cv::Rect(cv::Point(0, 0), frames.images[i].size());
      const cv::Mat patch = channel(frames.images[static_cast<std::size_t>(i)](roi));
      double sky = 0.0, marker = 0.0;
      cv::minMaxLoc(patch, &sky, &marker);
      ASSERT_GT(marker - sky, 50.0);
      double sum = 0.0, sx = 0.0, sy = 0.0;
      for (int y = 0; y < patch.rows; ++y) {
        for (int x = 0; x < patch.cols; ++x) {
          const double coverage = (patch.at<double>(y, x) - sky) / (marker - sky);
          sum += coverage;
          sx += coverage * (roi.x + x);
          sy += coverage * (roi.y + y);
        }
      }
      EXPECT_NEAR(sx / sum, expected.x(), 0.1);
      EXPECT_NEAR(sy / sum, expected.y(), 0.1);
      worst_px = std::max(worst_px, (Eigen::Vector2d(sx / sum, sy / sum) - expected).norm());
      // The truth box is the silhouette's extent: it holds the centre, about one diameter wide.
      const auto& box = *t.boxes[static_cast<std::size_t>(i)];
      EXPECT_GT(expected.x(), box.x_min);
      EXPECT_LT(expected.x(), box.x_max);
      const double diameter_px = 2.0 * std::sqrt(sum / M_PI);
      EXPECT_NEAR(box.x_max - box.x_min, diameter_px, 0.25 * diameter_px + 0.5);
    }
  }
  std::cout << "marker centroid vs model projection, 4 markers x 4 cameras: largest error "
            << worst_px << " px\n";
}

// Sub-pixel horizontal shift of `left_patch` found in `right` around the given rows/columns:
// normalised cross-correlation and a parabola through the peak.
double match_column(const cv::Mat& left, const cv::Rect& patch, const cv::Mat& right,
                    double predicted_shift, int search) {
  const cv::Rect strip(patch.x - static_cast<int>(std::lround(predicted_shift)) - search, patch.y,
                       patch.width + 2 * search, patch.height);
  cv::Mat response;
  cv::matchTemplate(right(strip), left(patch), response, cv::TM_CCOEFF_NORMED);
  cv::Point peak;
  double best = 0.0;
  cv::minMaxLoc(response, nullptr, &best, nullptr, &peak);
  EXPECT_GT(best, 0.8);
  double offset = peak.x;
  if (peak.x > 0 && peak.x + 1 < response.cols) {
    const double a = response.at<float>(0, peak.x - 1), b = response.at<float>(0, peak.x),
                 c = response.at<float>(0, peak.x + 1);
    offset += 0.5 * (a - c) / (a - 2.0 * b + c);
  }
  return patch.x - (strip.x + offset);  // left column - right column
}

TEST(SimulatedRig, RectifiedDisparityMatchesTheTrueDistance) {
  // Flat textured boards (car-shaped boxes turned to face the rig) at known distances. In the
  // equirectangular rectified grid a point's columns differ by f * (alpha_L - alpha_R), about
  // f * B / L straight ahead.
  const auto scene = thermovis::runtime::parse_scene(R"(name: boards
textures:
  speckle: {pattern: noise, colour_rgb: [0.75, 0.65, 0.55], colour2_rgb: [0.1, 0.12, 0.15],
            scale_m: 0.05, contrast: 0.6, temperature_c: 35, temperature_contrast_k: 4}
targets:
  - {id: near, class: car, distance_m: 12, bearing_deg: -25, heading_deg: -25, width_m: 2.4,
     height_m: 2.0, texture: speckle}
  - {id: mid, class: car, distance_m: 20, bearing_deg: 5, heading_deg: 5, width_m: 2.4,
     height_m: 2.0, texture: speckle}
  - {id: far, class: car, distance_m: 30, bearing_deg: 20, heading_deg: 20, width_m: 2.4,
     height_m: 2.0, texture: speckle}
)",
                                                     "boards");
  const SimulatedRig sim(paper_rig(), scene, 11);
  FrameSet frames = sim.allocate();
  sim.render(0, frames);
  const auto& rig = sim.rig();
  double worst_px = 0.0;
  for (const bool visible : {true, false}) {
    const auto& pair = visible ? rig.visible : rig.infrared;
    const auto geometry = thermovis::rectify::make_stereo_geometry(
        rig, pair, thermovis::rectify::default_pair_grid(rig, pair));
    const Slot left_slot = visible ? Slot::visible_left : Slot::infrared_left;
    const Slot right_slot = visible ? Slot::visible_right : Slot::infrared_right;
    cv::Mat rect[2];
    for (int eye = 0; eye < 2; ++eye) {
      const auto& cam = rig.camera(eye == 0 ? pair.left : pair.right);
      const cv::Mat map = thermovis::rectify::build_map(
          cam, eye == 0 ? geometry.T_ref_left_rect : geometry.T_ref_right_rect, geometry.grid);
      const cv::Mat raw = channel(frames[eye == 0 ? left_slot : right_slot]);
      cv::Mat raw32;
      raw.convertTo(raw32, CV_32F);
      cv::remap(raw32, rect[eye], map, cv::noArray(), cv::INTER_LINEAR);
    }
    for (const auto& target : scene.targets) {
      SCOPED_TRACE(target.id + (visible ? " visible" : " infrared"));
      // Centre of the board's front face (the body box: 0.2 .. 0.6 of the height).
      const auto t = thermovis::sim::with_class_defaults(target);
      const double heading = t.heading_deg * M_PI / 180.0;
      const Eigen::Vector3d foot = thermovis::sim::foot_position(scene, t, 0.0);
      const Eigen::Vector3d face =
          foot + Eigen::Vector3d(-std::sin(heading) * 0.5 * t.length_m, -0.4 * t.height_m,
                                 -std::cos(heading) * 0.5 * t.length_m);
      Eigen::Vector2d pl, pr;
      ASSERT_TRUE(geometry.grid.project(geometry.T_ref_left_rect.inverse() * face, pl));
      ASSERT_TRUE(geometry.grid.project(geometry.T_ref_right_rect.inverse() * face, pr));
      EXPECT_NEAR(pl.y(), pr.y(), 0.05);  // same epipolar row
      const double expected = pl.x() - pr.x();
      const double range = (face - geometry.T_ref_left_rect.translation()).norm();
      // To first order in B / L the angles differ by B cos(alpha) / L: f * B / L straight ahead.
      const double alpha = geometry.grid.alpha_of_column(pl.x());
      EXPECT_NEAR(expected,
                  geometry.grid.intrinsics().f * geometry.baseline_m * std::cos(alpha) / range,
                  0.05 * expected);
      // A patch of half the face's size around its centre.
      const double px_per_m = geometry.grid.intrinsics().f / range;
      const int w = std::max(9, static_cast<int>(0.5 * t.width_m * px_per_m)) | 1;
      const int h = std::max(5, static_cast<int>(0.2 * t.height_m * px_per_m)) | 1;
      const cv::Rect patch(static_cast<int>(std::lround(pl.x())) - w / 2,
                           static_cast<int>(std::lround(pl.y())) - h / 2, w, h);
      const double measured = match_column(rect[0], patch, rect[1], expected, 6);
      EXPECT_NEAR(measured, expected, 0.25) << "expected " << expected << " px";
      worst_px = std::max(worst_px, std::abs(measured - expected));
    }
  }
  std::cout << "rectified disparity, 3 boards x 2 pairs: largest |measured - true| " << worst_px
            << " px\n";
}

TEST(SimulatedRig, SameSeedSameBytesInAnyFrameOrder) {
  const auto scene = shipped("street");
  const SimulatedRig a(paper_rig(), scene, 7);
  const SimulatedRig b(paper_rig(), scene, 7);
  const FrameSet fa = rendered(a, 40);
  FrameSet fb = rendered(b, 41);
  b.render(40, fb);  // over another frame: nothing of frame 41 may remain
  const FrameSet again = rendered(a, 40);
  EXPECT_GT(a.dynamic_pixel_count(40), 0);  // moving targets were drawn
  for (int i = 0; i < thermovis::sim::kSlotCount; ++i) {
    SCOPED_TRACE(to_string(static_cast<Slot>(i)));
    EXPECT_EQ(cv::norm(fa.images[i], fb.images[i], cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(fa.images[i], again.images[i], cv::NORM_INF), 0.0);
  }
}

TEST(SimulatedRig, DifferentSeedsOrFramesGiveDifferentNoiseOfTheStatedSize) {
  const auto scene = shipped("street");
  const SimulatedRig a(paper_rig(), scene, 7);
  const SimulatedRig c(paper_rig(), scene, 8);
  const FrameSet f0 = rendered(a, 10), f1 = rendered(a, 11), other = rendered(c, 10);
  for (int i = 0; i < thermovis::sim::kSlotCount; ++i) {
    SCOPED_TRACE(to_string(static_cast<Slot>(i)));
    EXPECT_GT(cv::norm(f0.images[i], other.images[i], cv::NORM_L1), 0.0);
    EXPECT_GT(cv::norm(f0.images[i], f1.images[i], cv::NORM_L1), 0.0);
    // Zero-mean noise: the two seeds' images agree on average (to within what the infrared
    // column offsets, one per column, leave in a mean: 4 sigma).
    cv::Mat diff;
    cv::subtract(channel(f0.images[i]), channel(other.images[i]), diff);
    const double column_spread = i < 2 ? 0.0
                                       : 4.0 * std::sqrt(2.0) * scene.infrared.fpn_column_counts /
                                             std::sqrt(static_cast<double>(diff.cols));
    EXPECT_LT(std::abs(cv::mean(diff)[0]), 0.3 + column_spread);
  }
  // Infrared temporal noise: the top rows (sky and walls: static) of two frames differ by
  // sqrt(2) * NETD * counts_per_k (2.5 counts per frame for the street scene).
  const double sigma = scene.infrared.netd_k * scene.infrared.counts_per_k;
  for (const Slot slot : {Slot::infrared_left, Slot::infrared_right}) {
    const cv::Rect top(0, 0, f0[slot].cols, 100);
    cv::Mat diff;
    cv::subtract(channel(f0[slot](top)), channel(f1[slot](top)), diff);
    cv::Scalar mean, stddev;
    cv::meanStdDev(diff, mean, stddev);
    EXPECT_NEAR(stddev[0], std::sqrt(2.0) * sigma, 0.1 * std::sqrt(2.0) * sigma);
  }
}

// Contrast of a target against the ring around it (positive: the target is brighter or
// warmer), in units of the per-pixel temporal noise.
double contrast_to_noise(const cv::Mat& frame_a, const cv::Mat& frame_b,
                         const thermovis::sim::TruthBox& box) {
  const cv::Mat a = channel(frame_a), b = channel(frame_b);
  const cv::Rect outer = box_rect(box, 12) & cv::Rect(cv::Point(0, 0), a.size());
  const cv::Rect body = box_rect(box, 0);
  const cv::Rect inner(body.x + body.width / 3, body.y + body.height / 4, body.width / 3,
                       body.height / 2);
  cv::Mat ring_mask(a.size(), CV_8U, cv::Scalar(0));
  ring_mask(outer).setTo(255);
  ring_mask(body & outer).setTo(0);
  const double target = cv::mean(a(inner))[0];
  const double ring = cv::mean(a, ring_mask)[0];
  cv::Mat diff;
  cv::subtract(a, b, diff);
  cv::Scalar mean, stddev;
  cv::meanStdDev(diff, mean, stddev, ring_mask);
  return (target - ring) / (stddev[0] / std::sqrt(2.0));
}

TEST(SimulatedRig, AtNightTheVisibleBandSeesLittleAndTheInfraredBandSeesPeople) {
  const SimulatedRig sim(paper_rig(), shipped("night"), 5);
  FrameSet f0 = sim.allocate(), f1 = sim.allocate();
  sim.render(0, f0);
  sim.render(1, f1);
  const auto truth = sim.truth(0);
  for (const char* id : {"person_10m", "person_20m"}) {
    SCOPED_TRACE(id);
    const TargetTruth& person = find(truth, id);
    const double visible = contrast_to_noise(f0[Slot::visible_left], f1[Slot::visible_left],
                                             *person.boxes[static_cast<int>(Slot::visible_left)]);
    const double infrared = contrast_to_noise(f0[Slot::infrared_left], f1[Slot::infrared_left],
                                              *person.boxes[static_cast<int>(Slot::infrared_left)]);
    EXPECT_LT(std::abs(visible), 2.0);
    EXPECT_GT(infrared, 20.0);  // warmer than the street around it, far above the noise
  }
  // The visible image is dark: mean under 10 DN of 255.
  EXPECT_LT(cv::mean(f0[Slot::visible_left])[1], 10.0);
}

TEST(SimulatedRig, TruthFollowsTheTrajectoryAndBuffersAreChecked) {
  const auto scene = thermovis::runtime::parse_scene(R"(name: walk
targets:
  - {id: walker, class: person, distance_m: 10, bearing_deg: 0, velocity_mps: [1.0, -2.0]}
)",
                                                     "walk");
  const SimulatedRig sim(paper_rig(), scene, 1);
  const auto start = sim.truth(0).at(0);
  const auto later = sim.truth(100).at(0);  // 2 s at 50 Hz
  EXPECT_NEAR(start.position_m.z(), 10.0, 1e-9);
  EXPECT_NEAR(start.position_m.y(), 1.4 - 0.875, 1e-9);  // box centre below the camera
  EXPECT_NEAR(later.position_m.x() - start.position_m.x(), 2.0, 1e-9);
  EXPECT_NEAR(later.position_m.z() - start.position_m.z(), -4.0, 1e-9);
  EXPECT_NEAR(later.distance_m, later.position_m.norm(), 1e-12);
  // Nearer: a taller box.
  const auto& b0 = *start.boxes[0];
  const auto& b1 = *later.boxes[0];
  EXPECT_GT(b1.y_max - b1.y_min, 1.5 * (b0.y_max - b0.y_min));

  FrameSet frames = sim.allocate();
  frames[Slot::infrared_right] = cv::Mat(768, 1024, CV_8UC1);
  EXPECT_THROW(sim.render(0, frames), std::invalid_argument);
  frames = sim.allocate();
  frames[Slot::visible_left] = cv::Mat(1080, 1920, CV_8UC3).colRange(0, 1000);
  EXPECT_THROW(sim.render(0, frames), std::invalid_argument);
}

}  // namespace
