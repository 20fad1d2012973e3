// The rig pipeline on a simulated frame (the paper's Table 6 scene: people at 5-60 m): visible
// ranging of the truth boxes against the true distances, and bad frames.
#include <gtest/gtest.h>

#include <cmath>

#include "thermovis/range/stereo_ranger.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace rg = thermovis::range;
namespace sim = thermovis::sim;

TEST(StereoRanger, SimulatedPeopleWithinTwoPercentTo30m) {
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  const auto scene =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("paper"));
  const sim::SimulatedRig simulated(rig, scene, 3);
  sim::FrameSet frames = simulated.allocate();
  simulated.render(0, frames);
  const rg::StereoRanger ranger(rig);
  const rg::RectifiedFrames rectified =
      ranger.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                      frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
  rg::RangerOptions options;
  options.centre_offset_m = rg::surface_to_centre_m("person");
  int ranged = 0;
  for (const auto& t : simulated.truth(0)) {
    if (t.cls != sim::TargetClass::person || t.distance_m > 31) continue;
    const auto& b = t.boxes[static_cast<size_t>(sim::Slot::visible_left)];
    ASSERT_TRUE(b.has_value()) << t.id;
    const cv::Rect box =
        ranger.raw_box_to_rectified(rg::Mode::visible, b->x_min, b->y_min, b->x_max, b->y_max);
    const rg::RangedTarget r = ranger.range(rectified, rg::Mode::visible, box, options);
    ASSERT_EQ(r.range.status, rg::RangeStatus::ok) << t.id << ": " << r.range.message;
    std::cout << t.id << ": " << r.range.distance_m << " m (truth " << t.distance_m << ", sigma "
              << r.range.sigma_m << ", " << r.range.points_used << " points)\n";
    // Measured (seed 3): errors 0.01-0.36 m from 5 to 30 m.
    EXPECT_LT(std::abs(r.range.distance_m - t.distance_m), 0.02 * t.distance_m + 0.1) << t.id;
    // The position is the distance along the target's direction (rig frame).
    EXPECT_NEAR(r.range.position_m.norm(), r.range.distance_m, 1e-6);
    ++ranged;
  }
  EXPECT_EQ(ranged, 6);
}

TEST(StereoRanger, BadFramesAreClearErrors) {
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  const rg::StereoRanger ranger(rig);
  rg::RawFrames raw;
  EXPECT_THROW(ranger.rectify(raw), std::invalid_argument);  // no images
  raw.visible_left = cv::Mat(10, 10, CV_8UC3);
  raw.visible_right = cv::Mat(10, 10, CV_8UC3);
  EXPECT_THROW(ranger.rectify(raw), std::invalid_argument);  // wrong size
  EXPECT_THROW(rg::parse_mode("thermal"), std::invalid_argument);
}
