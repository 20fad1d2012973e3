// The obstacle stage (common/obstacle) on one capture of the simulated street scene, rectified
// onto the pipeline grid (0.5 of the visible pair's default grid, 936 x 566 for the paper rig),
// one core: both pairs (the default; with the ground tracked from frame to frame; without
// narrow obstacles ranged again on the grid's pixels, ObstacleOptions::refine; without runs
// that stand as a whole, ObstacleOptions::vertical_max_share; without the far band on the
// grid's own pixels, ObstacleOptions::far_band), the
// visible pair alone, the infrared pair alone, and the parts of one visible pair (dense
// disparity; the ground, stixels and obstacles after it). The real-time budget is 5 ms of CPU
// per capture for the whole stage (issue 18).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "thermovis/obstacle/block_matching.hpp"
#include "thermovis/obstacle/obstacles.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace {

namespace ob = thermovis::obstacle;
namespace pl = thermovis::pipeline;
namespace sim = thermovis::sim;

struct Fixture {
  Fixture() {
    const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
    const sim::Scene scene =
        thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("street"));
    const sim::SimulatedRig simulated(rig, scene, 1);
    sim::FrameSet frames = simulated.allocate();
    simulated.render(0, frames);
    pl::CapturePipeline pipeline(rig);
    capture =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    const pl::PipelineGeometry& g = pipeline.geometry();
    ob::GroundPrior prior;
    prior.camera_height_m = scene.camera_height_m;
    const std::vector<ob::PairSetup> pairs{
        {ob::PairBand::visible, g.ranging(pl::Band::visible)},
        {ob::PairBand::infrared, g.ranging(pl::Band::infrared), g.infrared_reduction}};
    const auto make = [&](const ob::ObstacleOptions& options) {
      return std::make_unique<ob::ObstacleDetector>(g.grid, pairs, g.T_ref_reporting, prior,
                                                    options);
    };
    ob::ObstacleOptions unrefined, pixels_standing, reduced_only;
    unrefined.refine = false;
    pixels_standing.vertical_max_share = 0;
    reduced_only.far_band = false;
    detectors = {make(unrefined), make({}), make(pixels_standing), make(reduced_only)};
  }
  pl::GridCapture capture;
  // BM_ObstaclesBothPairs' variants, by its argument.
  std::array<std::unique_ptr<ob::ObstacleDetector>, 4> detectors;
};

const Fixture& fixture() {
  cv::setNumThreads(1);
  static const Fixture f;
  return f;
}

void BM_ObstaclesBothPairs(benchmark::State& state) {
  const Fixture& f = fixture();
  const auto variant = static_cast<std::size_t>(state.range(0));
  const std::array<const char*, 4> labels{"narrow ones not refined", "the default",
                                          "no runs standing as a whole", "no far band"};
  state.SetLabel(labels.at(variant));
  const ob::ObstacleDetector& detector = *f.detectors.at(variant);
  std::size_t found = 0;
  for (auto _ : state) {
    const ob::ObstacleResult r = detector.detect(f.capture.grey_left, f.capture.grey_right,
                                                 f.capture.infrared_left, f.capture.infrared_right);
    found = r.obstacles.size();
    benchmark::DoNotOptimize(found);
  }
  state.counters["obstacles"] = static_cast<double>(found);
}
BENCHMARK(BM_ObstaclesBothPairs)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

// The same, each pair's ground searched about the last frame's (GroundTracks): the narrower
// search of every frame after the first.
void BM_ObstaclesBothPairsTracked(benchmark::State& state) {
  const Fixture& f = fixture();
  ob::GroundTracks tracks;
  std::size_t found = 0;
  for (auto _ : state) {
    const ob::ObstacleResult r =
        f.detectors[1]->detect(f.capture.grey_left, f.capture.grey_right, f.capture.infrared_left,
                               f.capture.infrared_right, tracks);
    found = r.obstacles.size();
    benchmark::DoNotOptimize(found);
  }
  state.counters["obstacles"] = static_cast<double>(found);
}
BENCHMARK(BM_ObstaclesBothPairsTracked)->Unit(benchmark::kMillisecond);

void BM_ObstaclesOnePair(benchmark::State& state) {
  const Fixture& f = fixture();
  const bool visible = state.range(0) == 0;
  state.SetLabel(visible ? "visible" : "infrared");
  for (auto _ : state) {
    const ob::PairObstacles r =
        visible ? f.detectors[1]->detect_pair(ob::PairBand::visible, f.capture.grey_left,
                                              f.capture.grey_right)
                : f.detectors[1]->detect_pair(ob::PairBand::infrared, f.capture.infrared_left,
                                              f.capture.infrared_right);
    benchmark::DoNotOptimize(r.obstacles.size());
  }
}
BENCHMARK(BM_ObstaclesOnePair)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// The visible pair's parts: reduction + dense disparity, then the rest from the disparity.
void BM_VisibleDenseDisparity(benchmark::State& state) {
  const Fixture& f = fixture();
  for (auto _ : state) {
    cv::Mat l8, r8;
    f.detectors[1]->reduce_pair(ob::PairBand::visible, f.capture.grey_left, f.capture.grey_right,
                                l8, r8);
    const cv::Mat d = ob::dense_disparity(l8, r8, f.detectors[1]->max_disparity_px(),
                                          f.detectors[1]->options().dense);
    benchmark::DoNotOptimize(d.data);
  }
}
BENCHMARK(BM_VisibleDenseDisparity)->Unit(benchmark::kMillisecond);

void BM_VisibleFromDisparity(benchmark::State& state) {
  const Fixture& f = fixture();
  cv::Mat l8, r8;
  f.detectors[1]->reduce_pair(ob::PairBand::visible, f.capture.grey_left, f.capture.grey_right, l8,
                              r8);
  const cv::Mat d = ob::dense_disparity(l8, r8, f.detectors[1]->max_disparity_px(),
                                        f.detectors[1]->options().dense);
  for (auto _ : state) {
    const ob::PairObstacles r = f.detectors[1]->from_disparity(ob::PairBand::visible, d);
    benchmark::DoNotOptimize(r.obstacles.size());
  }
}
BENCHMARK(BM_VisibleFromDisparity)->Unit(benchmark::kMillisecond);

// Block matching of one reduced pair as the stage does it (its range, block, texture threshold
// and uniqueness; 0: visible, 1: infrared, its right eye resampled onto the left's rows), ours
// (obstacle::block_match) against OpenCV's cv::StereoBM, which it equals to the bit, both
// without the speckle filter they share. Compare the two in one run.
struct ReducedPair {
  cv::Mat left, right;
  ob::BlockMatchParams params;
};

ReducedPair reduced_pair(const Fixture& f, int band) {
  ReducedPair p;
  const ob::ObstacleDetector& detector = *f.detectors[1];
  const bool visible = band == 0;
  detector.reduce_pair(visible ? ob::PairBand::visible : ob::PairBand::infrared,
                       visible ? f.capture.grey_left : f.capture.infrared_left,
                       visible ? f.capture.grey_right : f.capture.infrared_right, p.left, p.right);
  ob::DenseOptions dense = detector.options().dense;
  if (!visible) dense.texture_noise_factor = detector.options().counts_texture_noise_factor;
  p.params.disparities = 16 * static_cast<int>(std::ceil(detector.max_disparity_px() / 16.0));
  p.params.block = dense.block_size;
  p.params.texture_threshold = ob::block_texture_threshold(p.left, dense);
  p.params.uniqueness_ratio =
      visible ? dense.uniqueness_ratio : detector.options().off_axis_uniqueness_ratio;
  return p;
}

void BM_BlockMatchOurs(benchmark::State& state) {
  const ReducedPair p = reduced_pair(fixture(), static_cast<int>(state.range(0)));
  state.SetLabel(state.range(0) == 0 ? "visible" : "infrared");
  cv::Mat d;
  for (auto _ : state) {
    ob::block_match(p.left, p.right, p.params, d);
    benchmark::DoNotOptimize(d.data);
  }
}
BENCHMARK(BM_BlockMatchOurs)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_BlockMatchOpenCv(benchmark::State& state) {
  const ReducedPair p = reduced_pair(fixture(), static_cast<int>(state.range(0)));
  state.SetLabel(state.range(0) == 0 ? "visible" : "infrared");
  const cv::Ptr<cv::StereoBM> bm = cv::StereoBM::create(p.params.disparities, p.params.block);
  bm->setPreFilterCap(p.params.prefilter_cap);
  bm->setTextureThreshold(p.params.texture_threshold);
  bm->setUniquenessRatio(p.params.uniqueness_ratio);
  bm->setSpeckleWindowSize(0);
  cv::Mat d;
  for (auto _ : state) {
    bm->compute(p.left, p.right, d);
    benchmark::DoNotOptimize(d.data);
  }
}
BENCHMARK(BM_BlockMatchOpenCv)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
