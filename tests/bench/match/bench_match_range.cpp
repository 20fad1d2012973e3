// Matching + ranging of one target box on a full-resolution rectified pair (the paper's visible
// grid, 1864 x 1082), one core. The paper's TX2 takes 16 ms (SURF + RANSAC) + 0.1 ms (ranging).
// The pair is a seeded synthetic texture; the box is a person-sized target at 5 m and at 20 m
// (its disparity on the grid of 835.4 px per rad with the 0.335 m baseline).
// BM_AlignRegionAndRange is the whole-target disparity (match::align_region) of a person's
// silhouette at 5-100 m and its range; its disparity_error_px counter is against the exact shift.
#include <benchmark/benchmark.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/match/region_align.hpp"
#include "thermovis/match/stereo_match.hpp"
#include "thermovis/range/ranging.hpp"

namespace {

namespace mt = thermovis::match;
namespace rg = thermovis::range;

constexpr int kWidth = 1864, kHeight = 1082;
constexpr double kF = 835.4, kBaseline = 0.335;

struct Pair {
  cv::Mat left, right;
};

// Texture shifted by the target's disparity inside the box's rows and columns (or, with
// `ellipse`, inside the ellipse that fills the box: a person's silhouette), the background behind
// by 2 px.
Pair make_pair(double distance_m, const cv::Rect& box, bool ellipse = false) {
  cv::setNumThreads(1);
  cv::Mat noise(kHeight, kWidth, CV_32F);
  cv::RNG rng(11);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.2);
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  const double disparity = kF * kBaseline / distance_m;
  cv::Mat map_x(noise.size(), CV_32F), map_y(noise.size(), CV_32F);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      // Right image: the target's pixels come from left column x + d.
      const double u = x + disparity;
      bool in_target = y >= box.y && y < box.br().y && u >= box.x && u < box.br().x;
      if (ellipse && in_target) {
        const double ex = (u - box.x + 0.5) / box.width - 0.5,
                     ey = (y - box.y + 0.5) / box.height - 0.5;
        in_target = ex * ex + ey * ey <= 0.25;
      }
      map_x.at<float>(y, x) = static_cast<float>(x + (in_target ? disparity : 2.0));
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  Pair p;
  noise.convertTo(p.left, CV_8U);
  cv::Mat shifted;
  cv::remap(noise, shifted, map_x, map_y, cv::INTER_CUBIC, cv::BORDER_REFLECT);
  shifted.convertTo(p.right, CV_8U);
  return p;
}

// The benchmark's rectified pair: kWidth x kHeight pixels, focal length kF px, principal point
// at the centre, right eye kBaseline m along x.
rg::RangingGeometry bench_geometry() {
  thermovis::camera::RectifiedIntrinsics g;
  g.width = kWidth;
  g.height = kHeight;
  g.f = kF;
  g.cx = (kWidth - 1) / 2.0;
  g.cy = (kHeight - 1) / 2.0;
  return {thermovis::camera::RectifiedCamera(g), kBaseline, Eigen::Isometry3d::Identity()};
}

void BM_MatchAndRange(benchmark::State& state) {
  const double distance = static_cast<double>(state.range(0));
  // Person 1.75 x 0.5 m at that distance, left of centre.
  const int h = static_cast<int>(1.75 / distance * kF), w = static_cast<int>(0.5 / distance * kF);
  const cv::Rect box(kWidth / 2 - 200, kHeight / 2 - h / 2, w, h);
  const Pair pair = make_pair(distance, box);
  cv::setNumThreads(1);
  mt::MatchOptions mo;
  mo.method = static_cast<mt::Method>(state.range(1));
  mo.max_disparity_px = kF * kBaseline / 2.5;
  const rg::RangingGeometry geometry = bench_geometry();
  size_t points = 0;
  double distance_m = 0;
  for (auto _ : state) {
    const mt::MatchResult m = mt::match_box(pair.left, pair.right, box, mo);
    const rg::TargetRange r = rg::range_target(geometry, box, m.matches);
    points = m.matches.size();
    distance_m = r.distance_m;
    benchmark::DoNotOptimize(r);
  }
  state.counters["matches"] = static_cast<double>(points);
  state.counters["distance_m"] = distance_m;
  state.SetLabel(mt::method_name(mo.method) + " box " + std::to_string(w) + "x" +
                 std::to_string(h));
}

// Whole-target disparity (match::align_region) of a person's silhouette (an ellipse filling the
// box) and its range, as pipeline::MatchStage and RangeStage do for a box with few points.
void BM_AlignRegionAndRange(benchmark::State& state) {
  const double distance = static_cast<double>(state.range(0));
  const int h = std::max(4, static_cast<int>(1.75 / distance * kF)),
            w = std::max(2, static_cast<int>(0.5 / distance * kF));
  const cv::Rect box(kWidth / 2 - 200, kHeight / 2 - h / 2, w, h);
  const Pair pair = make_pair(distance, box, true);
  cv::Mat mask(box.size(), CV_8UC1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double ex = (x + 0.5) / w - 0.5, ey = (y + 0.5) / h - 0.5;
      mask.at<uchar>(y, x) = ex * ex + ey * ey <= 0.25 ? 255 : 0;
    }
  cv::setNumThreads(1);
  mt::RegionOptions o;
  o.max_disparity_px = kF * kBaseline / 2.5;
  const rg::RangingGeometry geometry = bench_geometry();
  mt::RegionDisparity region;
  double distance_m = 0;
  for (auto _ : state) {
    region = mt::align_region(pair.left, pair.right, box, mask, std::nan(""), o);
    const rg::TargetRange r = rg::range_region(geometry, box, region, 0.0);
    distance_m = r.distance_m;
    benchmark::DoNotOptimize(r);
  }
  if (!region.ok()) state.SkipWithError(region.message.c_str());
  state.counters["pixels"] = region.pixels;
  state.counters["disparity_error_px"] = region.disparity_px - kF * kBaseline / distance;
  state.counters["distance_m"] = distance_m;
  state.SetLabel("box " + std::to_string(w) + "x" + std::to_string(h));
}

void BM_RangeOnly(benchmark::State& state) {
  const rg::RangingGeometry geometry = bench_geometry();
  std::vector<mt::Correspondence> matches(static_cast<size_t>(state.range(0)));
  cv::RNG rng(3);
  for (auto& c : matches) {
    c.left = {700 + rng.uniform(0, 40), 500 + rng.uniform(0, 100)};
    c.disparity_px = 14.0 + rng.gaussian(0.1);
  }
  for (auto _ : state)
    benchmark::DoNotOptimize(rg::range_target(geometry, cv::Rect(700, 500, 40, 100), matches));
}

}  // namespace

BENCHMARK(BM_MatchAndRange)
    ->ArgsProduct({{5, 20},
                   {static_cast<int>(mt::Method::ncc), static_cast<int>(mt::Method::orb),
                    static_cast<int>(mt::Method::sift)}})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AlignRegionAndRange)
    ->Arg(5)
    ->Arg(20)
    ->Arg(40)
    ->Arg(60)
    ->Arg(100)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RangeOnly)->Arg(30)->Arg(300)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
