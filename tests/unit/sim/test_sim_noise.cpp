// The simulated rig's noise has the statistics the scene states, and no structure a stereo
// matcher could lock onto: temporal noise of the right size and Gaussian shape, independent
// between the two eyes (at every shift a matcher would try), between frames and between seeds;
// infrared fixed-pattern noise of the stated size, fixed over frames and independent per camera.
// Measured on the uniform sky of a scene without walls or targets, against the noise-free render
// of the same seed, with the expected sizes derived here from the scene's parameters alone.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "rendered.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

using thermovis::sim::FrameSet;
using thermovis::sim::RenderOptions;
using thermovis::sim::SimulatedRig;
using thermovis::sim::Slot;

// Dusk light (gain 4: sky noise about 4 DN), an open plain under a uniform sky.
const char* const kFlatScene = R"(name: flat
visible: {illuminance_lux: 5, sky_colour_rgb: [0.6, 0.7, 0.8]}
infrared: {ambient_c: 10, sky_c: -10}
ground: {road_half_width_m: 0, centre_line: false}
)";

// Sky rectangles, well above the horizon and inside the lens's field.
const cv::Rect kVisibleSky(300, 20, 1320, 200);
const cv::Rect kInfraredSky(200, 20, 624, 150);

struct Renders {
  thermovis::sim::Scene scene;
  FrameSet noisy3, noisy4;  // seed 7, frames 3 and 4: temporal + fixed-pattern noise
  FrameSet fixed, fixed4;   // seed 7 without temporal noise (frames 3, 4): fixed pattern only
  FrameSet clean;           // no noise at all
  FrameSet other_seed;      // seed 8, frame 3, all noise
};

const Renders& renders() {
  static const Renders r = [] {
    Renders out;
    out.scene = thermovis::runtime::parse_scene(kFlatScene, "flat");
    const auto rig =
        thermovis::runtime::load_rig(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
    const SimulatedRig a(rig, out.scene, 7);
    out.noisy3 = rendered(a, 3);
    out.noisy4 = rendered(a, 4);
    RenderOptions fixed_only;
    fixed_only.temporal_noise = false;
    const SimulatedRig f(rig, out.scene, 7, fixed_only);
    out.fixed = rendered(f, 3);
    out.fixed4 = rendered(f, 4);
    RenderOptions none;
    none.temporal_noise = false;
    none.fixed_pattern = false;
    const SimulatedRig c(rig, out.scene, 7, none);
    out.clean = rendered(c, 3);
    const SimulatedRig b(rig, out.scene, 8);
    out.other_seed = rendered(b, 3);
    return out;
  }();
  return r;
}

cv::Rect sky(Slot slot) {
  return slot == Slot::visible_left || slot == Slot::visible_right ? kVisibleSky : kInfraredSky;
}

// One channel of a-b over the slot's sky rectangle, as doubles.
cv::Mat difference(const FrameSet& a, const FrameSet& b, Slot slot, int ch = 0) {
  cv::Mat ca, cb;
  cv::extractChannel(a[slot](sky(slot)), ca, ch);
  cv::extractChannel(b[slot](sky(slot)), cb, ch);
  ca.convertTo(ca, CV_64F);
  cb.convertTo(cb, CV_64F);
  return ca - cb;
}

// Zero mean, unit deviation.
cv::Mat standardised(const cv::Mat& m) {
  cv::Scalar mean, stddev;
  cv::meanStdDev(m, mean, stddev);
  cv::Mat out = (m - mean[0]) / stddev[0];
  return out;
}

// Largest |correlation| of a with b shifted by (dx, dy), over the shifts given: a(y, x) against
// b(y - dy, x - dx), on the overlap (both standardised over the whole field once).
double max_abs_correlation(const cv::Mat& a, const cv::Mat& b, int dx_min, int dx_max, int dy_min,
                           int dy_max) {
  const cv::Mat sa = standardised(a), sb = standardised(b);
  double worst = 0.0;
  for (int dy = dy_min; dy <= dy_max; ++dy) {
    for (int dx = dx_min; dx <= dx_max; ++dx) {
      const int w = a.cols - std::abs(dx), h = a.rows - std::abs(dy);
      const cv::Mat pa = sa(cv::Rect(std::max(dx, 0), std::max(dy, 0), w, h));
      const cv::Mat pb = sb(cv::Rect(std::max(-dx, 0), std::max(-dy, 0), w, h));
      worst = std::max(worst, std::abs(pa.dot(pb)) / static_cast<double>(w * h));
    }
  }
  return worst;
}

// Visible noise sigma (DN) at a clean value, from the scene's exposure model (scene.hpp): white
// collects min(illuminance * e/lux, 0.8 full well) electrons, the gain lifts that to 0.8 of full
// scale (up to max_gain); shot noise plus read noise.
double visible_sigma_dn(const thermovis::sim::VisibleBand& v, double dn) {
  const double target_e = 0.8 * v.full_well_e;
  const double white_e = std::min(v.illuminance_lux * v.electrons_per_lux, target_e);
  const double gain = std::clamp(target_e / white_e, 1.0, v.max_gain);
  const double dn_per_e = gain * 255.0 / v.full_well_e;
  const double read_dn = v.read_noise_e * dn_per_e;
  return std::sqrt(dn * dn_per_e + read_dn * read_dn);
}

TEST(SimNoise, TheSkyIsUniformWithoutNoise) {
  // The premise of the measurements below: the noise-free sky rectangles hold one value.
  const Renders& r = renders();
  for (const Slot slot :
       {Slot::visible_left, Slot::visible_right, Slot::infrared_left, Slot::infrared_right}) {
    SCOPED_TRACE(to_string(slot));
    const cv::Mat region = r.clean[slot](sky(slot));
    for (int ch = 0; ch < region.channels(); ++ch) {
      cv::Mat c;
      cv::extractChannel(region, c, ch);
      double lo = 0.0, hi = 0.0;
      cv::minMaxLoc(c, &lo, &hi);
      EXPECT_EQ(lo, hi);
      EXPECT_GT(lo, 20.0);  // far from the black clip
    }
  }
}

TEST(SimNoise, VisibleNoiseHasTheSceneSigmaAndAGaussianShape) {
  const Renders& r = renders();
  for (const Slot slot : {Slot::visible_left, Slot::visible_right}) {
    for (int ch = 0; ch < 3; ++ch) {
      SCOPED_TRACE(std::string(to_string(slot)) + " channel " + std::to_string(ch));
      const double dn = r.clean[slot](sky(slot)).at<cv::Vec3b>(0, 0)[ch];
      const double sigma = visible_sigma_dn(r.scene.visible, dn);
      // The output is rounded to whole DN: uniform rounding noise adds 1/12 DN^2.
      const double expected = std::sqrt(sigma * sigma + 1.0 / 12.0);
      const cv::Mat n = difference(r.noisy3, r.clean, slot, ch);
      cv::Scalar mean, stddev;
      cv::meanStdDev(n, mean, stddev);
      EXPECT_NEAR(mean[0], 0.0, 0.02 * sigma);
      EXPECT_NEAR(stddev[0], expected, 0.03 * expected);
      // Gaussian tails: the share of |noise| >= k DN for k about 3 sigma (a sum of a few
      // uniforms or a clipped table would have far fewer).
      const double k = std::ceil(3.0 * sigma);
      const double gaussian = std::erfc((k - 0.5) / (sigma * std::sqrt(2.0)));
      const cv::Mat magnitude = cv::abs(n);
      const cv::Mat beyond = magnitude >= k;
      const double tail =
          static_cast<double>(cv::countNonZero(beyond)) / static_cast<double>(n.total());
      EXPECT_NEAR(tail, gaussian, 0.2 * gaussian) << "k = " << k << " DN";
    }
  }
}

TEST(SimNoise, InfraredTemporalNoiseIsTheNetdAndFixedPatternNoiseHasTheStatedSize) {
  const Renders& r = renders();
  const auto& ir = r.scene.infrared;
  const double netd_counts = ir.netd_k * ir.counts_per_k;
  for (const Slot slot : {Slot::infrared_left, Slot::infrared_right}) {
    SCOPED_TRACE(to_string(slot));
    // Temporal: the noisy frame against the same seed's fixed-pattern-only frame.
    const cv::Mat n = difference(r.noisy3, r.fixed, slot);
    cv::Scalar mean, stddev;
    cv::meanStdDev(n, mean, stddev);
    const double expected = std::sqrt(netd_counts * netd_counts + 1.0 / 12.0);
    EXPECT_NEAR(mean[0], 0.0, 0.02 * netd_counts);
    EXPECT_NEAR(stddev[0], expected, 0.03 * expected);
    // Fixed pattern: offset + column offset + gain times the signal's distance from 20 C.
    const double signal = r.clean[slot](sky(slot)).at<std::uint16_t>(0, 0);
    const double gain_counts = ir.fpn_gain * (signal - ir.counts_at_20c);
    const double pixel_var =
        ir.fpn_offset_counts * ir.fpn_offset_counts + gain_counts * gain_counts;
    const double fpn_expected =
        std::sqrt(pixel_var + ir.fpn_column_counts * ir.fpn_column_counts + 1.0 / 6.0);
    const cv::Mat fpn = difference(r.fixed, r.clean, slot);
    cv::meanStdDev(fpn, mean, stddev);
    EXPECT_NEAR(stddev[0], fpn_expected, 0.05 * fpn_expected);
    // The column part: column means keep the column offset and 1/rows of the rest.
    cv::Mat columns;
    cv::reduce(fpn, columns, 0, cv::REDUCE_AVG);
    cv::meanStdDev(columns, mean, stddev);
    const double column_expected = std::sqrt(ir.fpn_column_counts * ir.fpn_column_counts +
                                             pixel_var / static_cast<double>(fpn.rows));
    EXPECT_NEAR(stddev[0], column_expected, 0.15 * column_expected);
    // Fixed: the same in the next frame.
    EXPECT_EQ(cv::norm(r.fixed[slot], r.fixed4[slot], cv::NORM_INF), 0.0);
  }
}

TEST(SimNoise, TheTwoEyesNoiseIsIndependentAtEveryDisparity) {
  // A matcher compares a left patch with right patches along the same row: the right image's
  // noise must not be a shifted copy of the left's at any disparity it tries (0-255 px), nor a
  // row away. Correlation of independent noise over these samples: about 0.002 (1 sigma).
  const Renders& r = renders();
  const cv::Mat vl = difference(r.noisy3, r.clean, Slot::visible_left, 1);
  const cv::Mat vr = difference(r.noisy3, r.clean, Slot::visible_right, 1);
  EXPECT_LT(max_abs_correlation(vl, vr, 0, 0, 0, 0), 0.01);
  EXPECT_LT(max_abs_correlation(vl, vr, 0, 255, -1, 1), 0.02);
  const cv::Mat il = difference(r.noisy3, r.fixed, Slot::infrared_left);
  const cv::Mat ir = difference(r.noisy3, r.fixed, Slot::infrared_right);
  EXPECT_LT(max_abs_correlation(il, ir, 0, 0, 0, 0), 0.015);
  EXPECT_LT(max_abs_correlation(il, ir, 0, 127, -1, 1), 0.025);
  // Fixed-pattern noise differs between the two infrared cameras.
  const cv::Mat fl = difference(r.fixed, r.clean, Slot::infrared_left);
  const cv::Mat fr = difference(r.fixed, r.clean, Slot::infrared_right);
  EXPECT_LT(max_abs_correlation(fl, fr, 0, 0, 0, 0), 0.02);
}

TEST(SimNoise, TemporalNoiseIsIndependentBetweenFramesAndSeeds) {
  // Consecutive frames (a static scene: anything shared would look like a still texture or a
  // small motion) and two seeds.
  const Renders& r = renders();
  for (const Slot slot : {Slot::visible_left, Slot::infrared_right}) {
    SCOPED_TRACE(to_string(slot));
    const FrameSet& base = slot == Slot::visible_left ? r.clean : r.fixed;
    const cv::Mat a = difference(r.noisy3, base, slot);
    const cv::Mat b = difference(r.noisy4, base, slot);
    EXPECT_LT(max_abs_correlation(a, b, 0, 0, 0, 0), 0.015);
    EXPECT_LT(max_abs_correlation(a, b, -32, 32, -2, 2), 0.025);
    // Seed 8 has its own fixed pattern: compare temporal + fixed noise of both seeds.
    const cv::Mat s7 = difference(r.noisy3, r.clean, slot);
    const cv::Mat s8 = difference(r.other_seed, r.clean, slot);
    EXPECT_LT(max_abs_correlation(s7, s8, 0, 0, 0, 0), 0.015);
  }
}

}  // namespace
