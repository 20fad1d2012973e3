// The whole-region alignment (match/region_align.hpp) on synthetic pairs whose disparities are
// exact: a target in front of a background at another disparity, rendered with area sampling,
// noise and a gain and offset between the eyes; and its statuses for regions it cannot align.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>
#include <random>

#include "thermovis/match/region_align.hpp"

namespace mt = thermovis::match;

namespace {

// A continuous texture: Gaussian blobs of random sign and size.
struct Texture {
  struct Blob {
    double x, y, a, s;
  };
  std::vector<Blob> blobs;
  double base = 0;
  Texture(unsigned seed, int count, double base_level, double amplitude, cv::Size extent) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(-30, extent.width + 30), uy(-10, extent.height + 10),
        ua(-amplitude, amplitude), us(1.0, 3.0);
    for (int i = 0; i < count; ++i) blobs.push_back({ux(rng), uy(rng), ua(rng), us(rng)});
    base = base_level;
  }
  double operator()(double x, double y) const {
    double v = base;
    for (const Blob& b : blobs) {
      const double dx = x - b.x, dy = y - b.y;
      if (std::abs(dx) > 4 * b.s || std::abs(dy) > 4 * b.s) continue;
      v += b.a * std::exp(-(dx * dx + dy * dy) / (2 * b.s * b.s));
    }
    return v;
  }
};

struct Scene {
  cv::Size size{160, 100};
  cv::Rect target{70, 30, 12, 36};  // the target's silhouette in the left image (a rectangle
                                    // with rounded top: a person-like blob)
  double target_disparity = 6.3, background_disparity = 2.1;
  std::function<double(double, double)> target_texture, background_texture;
  double gain = 1.0, offset = 0.0, noise = 1.0;
  double right_row_offset = 0.0;

  // The target's extent [x0, x1] on the row y of the left image (empty: x0 > x1): a rectangle
  // with a rounded top, a person-like blob.
  void span(double y, double& x0, double& x1) const {
    const double top = target.y - 0.5, r = 0.5 * target.width;
    const double cx = target.x + 0.5 * target.width - 0.5;
    x0 = 1, x1 = 0;
    if (y < top || y > target.br().y - 0.5) return;
    double half = r;
    if (y < top + r) half = std::sqrt(std::max(0.0, r * r - (y - top - r) * (y - top - r)));
    x0 = cx - half;
    x1 = cx + half;
  }
  // A pixel's value in eye 0 (left) or 1 (right: the scene shifted left by each layer's
  // disparity): the target's share of its area exactly along the row (four sub-rows), the
  // layers' textures at its centre.
  double pixel(int eye, int x, int y) const {
    const double xt = eye ? x + target_disparity : x, xb = eye ? x + background_disparity : x;
    const double yt = eye ? y - right_row_offset : y;
    double cover = 0;
    for (int j = 0; j < 4; ++j) {
      double x0, x1;
      span(yt - 0.375 + 0.25 * j, x0, x1);
      cover += 0.25 * std::max(0.0, std::min(x1, xt + 0.5) - std::max(x0, xt - 0.5));
    }
    return cover * target_texture(xt, yt) + (1 - cover) * background_texture(xb, yt);
  }
  void render(cv::Mat& left, cv::Mat& right, unsigned seed = 3) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, noise);
    for (int eye = 0; eye < 2; ++eye) {
      cv::Mat img(size, CV_64FC1);
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
          img.at<double>(y, x) = pixel(eye, x, y);
        }
      // The optics' blur, then noise and the right eye's gain and offset.
      cv::GaussianBlur(img, img, cv::Size(5, 5), 0.7);
      cv::Mat out(size, CV_8UC1);
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
          double v = img.at<double>(y, x) + n(rng);
          if (eye) v = gain * v + offset;
          out.at<uchar>(y, x) = cv::saturate_cast<uchar>(v);
        }
      (eye ? right : left) = out;
    }
  }
};

mt::RegionOptions wide_search() {
  mt::RegionOptions o;
  o.min_disparity_px = 0;
  o.max_disparity_px = 20;
  return o;
}

}  // namespace

TEST(AlignRegion, RecoversASubPixelShiftWithGainAndOffset) {
  const Texture tex(1, 900, 120, 50, {160, 100});
  for (double d : {3.0, 6.3, 9.75}) {
    Scene s;
    s.target_disparity = s.background_disparity = d;  // one plane: the whole box moves by d
    s.target_texture = s.background_texture = [&](double x, double y) { return tex(x, y); };
    s.gain = 1.15;
    s.offset = -12;
    s.right_row_offset = 0.2;
    cv::Mat L, R;
    s.render(L, R);
    const mt::RegionDisparity r =
        mt::align_region(L, R, cv::Rect(60, 25, 30, 45), cv::Mat(), NAN, wide_search());
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_NEAR(r.disparity_px, d, 0.03) << "shift " << d;
    EXPECT_NEAR(r.row_offset_px, 0.2, 0.03);
    EXPECT_NEAR(r.gain, 1 / 1.15, 0.02);  // g R + offset = L
    EXPECT_GT(r.zncc, 0.97);
    // The random part is small for 1350 px of texture, and not absurdly so.
    EXPECT_GT(r.sigma_px, 1e-4);
    EXPECT_LT(r.sigma_px, 0.02);
    EXPECT_NEAR(r.anchor.x(), 74.5, 1e-9);
    EXPECT_NEAR(r.anchor.y(), 47.0, 1e-9);
  }
}

TEST(AlignRegion, AWarmSilhouetteIsRangedAtItsOwnDisparityNotTheBackgrounds) {
  // A uniformly warm body (no texture inside: only its outline carries information) before a
  // textured background 4.2 px further away.
  const Texture bg(2, 900, 90, 40, {160, 100});
  Scene s;
  s.target_texture = [](double, double) { return 200.0; };
  s.background_texture = [&](double x, double y) { return bg(x, y); };
  cv::Mat L, R;
  s.render(L, R);
  const cv::Rect box(s.target.x - 1, s.target.y - 1, s.target.width + 2, s.target.height + 2);
  const cv::Mat mask = mt::target_silhouette(L, box);
  ASSERT_FALSE(mask.empty());
  const mt::RegionDisparity r = mt::align_region(L, R, box, mask, NAN, wide_search());
  ASSERT_TRUE(r.ok()) << r.message;
  // The outline's mixed pixels hold some of the background: a few hundredths of a pixel.
  EXPECT_NEAR(r.disparity_px, s.target_disparity, 0.06);
  // The inside is flat: the outline (its band and the ring around it) carries it all.
  EXPECT_GT(r.contour_fraction, 0.9);
  EXPECT_TRUE(r.ring_used);
}

TEST(AlignRegion, ATexturedTargetBeforeATexturedBackgroundIsAlignedWithoutTheRing) {
  // Clothing by day before a textured wall 4.2 px further away: the ring around the mask moves
  // with the wall, so the region correlates better without it and the ring is dropped.
  const Texture bg(6, 900, 100, 50, {160, 100}), cloth(7, 900, 120, 50, {160, 100});
  Scene s;
  s.target_texture = [&](double x, double y) { return cloth(x, y); };
  s.background_texture = [&](double x, double y) { return bg(x, y); };
  cv::Mat L, R;
  s.render(L, R);
  const cv::Rect box(s.target.x - 1, s.target.y - 1, s.target.width + 2, s.target.height + 2);
  // The silhouette: the pixels the target covers by more than half.
  cv::Mat mask(box.size(), CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < box.height; ++y)
    for (int x = 0; x < box.width; ++x) {
      double x0, x1;
      s.span(box.y + y, x0, x1);
      const double gx = box.x + x;
      if (std::min(x1, gx + 0.5) - std::max(x0, gx - 0.5) > 0.5) mask.at<uchar>(y, x) = 255;
    }
  const mt::RegionDisparity r = mt::align_region(L, R, box, mask, NAN, wide_search());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_FALSE(r.ring_used);
  // The mask's outline pixels are partly wall: -0.07 px here; with the ring it was -0.15 px.
  EXPECT_NEAR(r.disparity_px, s.target_disparity, 0.09);
}

TEST(AlignRegion, AFarTargetOfAFewPixelsStillAligns) {
  const Texture bg(4, 900, 90, 20, {160, 100});
  Scene s;
  s.target = cv::Rect(80, 40, 5, 14);
  s.target_disparity = 1.7;
  s.background_disparity = 0.9;
  s.target_texture = [](double, double) { return 170.0; };
  s.background_texture = [&](double x, double y) { return bg(x, y); };
  s.noise = 2.0;
  cv::Mat L, R;
  s.render(L, R);
  const cv::Rect box(79, 39, 7, 16);
  const mt::RegionDisparity r =
      mt::align_region(L, R, box, mt::target_silhouette(L, box), NAN, wide_search());
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_NEAR(r.disparity_px, 1.7, 0.15);
  EXPECT_LT(std::abs(r.disparity_px - 1.7), 4 * r.sigma_px + 0.05);
}

TEST(AlignRegion, AnInitialDisparityNarrowsTheSearch) {
  // Stripes repeat every 8 px: searched over 0-20 px two peaks correlate alike, around a
  // start the right one is found.
  Scene s;
  s.target_disparity = s.background_disparity = 5.4;
  s.target_texture = s.background_texture = [](double x, double y) {
    return 128 + 60 * std::sin(2 * M_PI * x / 8.0) + 0.0 * y;
  };
  s.noise = 0.5;
  cv::Mat L, R;
  s.render(L, R);
  const cv::Rect box(60, 30, 40, 30);
  const mt::RegionDisparity searched = mt::align_region(L, R, box, cv::Mat(), NAN, wide_search());
  EXPECT_EQ(searched.status, mt::RegionStatus::ambiguous) << searched.message;
  EXPECT_FALSE(std::isfinite(searched.disparity_px));
  mt::RegionOptions o = wide_search();
  o.search_radius_px = 2;
  const mt::RegionDisparity started = mt::align_region(L, R, box, cv::Mat(), 5.0, o);
  ASSERT_TRUE(started.ok()) << started.message;
  EXPECT_NEAR(started.disparity_px, 5.4, 0.02);
}

TEST(AlignRegion, RegionsItCannotAlignGiveAStatusNotANumber) {
  const Texture tex(5, 900, 120, 50, {160, 100});
  Scene s;
  s.target_texture = s.background_texture = [&](double x, double y) { return tex(x, y); };
  cv::Mat L, R;
  s.render(L, R);
  const mt::RegionOptions o = wide_search();
  auto expect = [&](const mt::RegionDisparity& r, mt::RegionStatus status) {
    EXPECT_EQ(r.status, status) << mt::region_status_name(r.status) << ": " << r.message;
    EXPECT_FALSE(r.message.empty());
    EXPECT_FALSE(std::isfinite(r.disparity_px));
    EXPECT_FALSE(std::isfinite(r.sigma_px));
  };
  // Outside the image, no area, an empty mask.
  expect(mt::align_region(L, R, cv::Rect(500, 10, 20, 20), cv::Mat(), NAN, o),
         mt::RegionStatus::empty_region);
  expect(mt::align_region(L, R, cv::Rect(10, 10, 0, 20), cv::Mat(), NAN, o),
         mt::RegionStatus::empty_region);
  expect(mt::align_region(L, R, cv::Rect(60, 30, 20, 20), cv::Mat::zeros(20, 20, CV_8UC1), NAN, o),
         mt::RegionStatus::empty_region);
  // A flat (or saturated) region.
  cv::Mat flat(L.size(), CV_8UC1, cv::Scalar(255));
  expect(mt::align_region(flat, flat, cv::Rect(60, 30, 20, 20), cv::Mat(), NAN, o),
         mt::RegionStatus::flat);
  // At the left edge: the right eye sees the region left of the image at every disparity >= 1.
  mt::RegionOptions far_only = o;
  far_only.min_disparity_px = 3;
  expect(mt::align_region(L, R, cv::Rect(0, 30, 2, 20), cv::Mat(), NAN, far_only),
         mt::RegionStatus::at_image_edge);
  // Cut by the image's edge.
  expect(mt::align_region(L, R, cv::Rect(150, 30, 20, 20), cv::Mat(), NAN, o),
         mt::RegionStatus::at_image_edge);
  // Two unrelated images.
  cv::Mat noise(L.size(), CV_8UC1);
  cv::randu(noise, 0, 255);
  const mt::RegionDisparity unrelated =
      mt::align_region(L, noise, cv::Rect(60, 30, 30, 30), cv::Mat(), NAN, o);
  EXPECT_FALSE(unrelated.ok());
  EXPECT_FALSE(std::isfinite(unrelated.disparity_px));
}

TEST(AlignRegion, WrongImagesOrMaskThrowNamingThem) {
  cv::Mat L(50, 60, CV_8UC1, cv::Scalar(0)), colour(50, 60, CV_8UC3), small(40, 60, CV_8UC1);
  const mt::RegionOptions o;
  EXPECT_THROW(mt::align_region(colour, L, cv::Rect(5, 5, 10, 10), cv::Mat(), NAN, o),
               std::invalid_argument);
  EXPECT_THROW(mt::align_region(L, small, cv::Rect(5, 5, 10, 10), cv::Mat(), NAN, o),
               std::invalid_argument);
  EXPECT_THROW(mt::align_region(L, L, cv::Rect(5, 5, 10, 10), cv::Mat(9, 10, CV_8UC1), NAN, o),
               std::invalid_argument);
  mt::RegionOptions inverted;
  inverted.min_disparity_px = 10;
  inverted.max_disparity_px = 2;
  try {
    mt::align_region(L, L, cv::Rect(5, 5, 10, 10), cv::Mat(), NAN, inverted);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_disparity_px"), std::string::npos) << e.what();
  }
}

TEST(TargetSilhouette, FindsAWarmOrAColdTargetAndNothingInAUniformBox) {
  const cv::Rect box(10, 10, 12, 30), body(13, 14, 6, 24);
  for (bool warm : {true, false}) {
    cv::Mat img(60, 40, CV_16UC1, cv::Scalar(8000));
    img(body).setTo(warm ? 9500 : 7000);
    const cv::Mat mask = mt::target_silhouette(img, box);
    ASSERT_FALSE(mask.empty()) << (warm ? "warm" : "cold");
    ASSERT_EQ(mask.size(), box.size());
    // The body, nothing else.
    cv::Mat expected(box.size(), CV_8UC1, cv::Scalar(0));
    expected(cv::Rect(body.tl() - box.tl(), body.size())).setTo(255);
    EXPECT_EQ(cv::countNonZero(mask != expected), 0) << (warm ? "warm" : "cold");
  }
  cv::Mat uniform(60, 40, CV_8UC1, cv::Scalar(100));
  EXPECT_TRUE(mt::target_silhouette(uniform, box).empty());
  // A box that is nearly all target does not split either.
  cv::Mat full(60, 40, CV_8UC1, cv::Scalar(100));
  full(cv::Rect(10, 10, 12, 30)).setTo(200);
  full.at<uchar>(10, 10) = 100;
  EXPECT_TRUE(mt::target_silhouette(full, box).empty());
  EXPECT_THROW(mt::target_silhouette(cv::Mat(20, 20, CV_32FC1), box), std::invalid_argument);
}
