// Cost of one frame set (four full-resolution raw images) of the simulated rig on one thread,
// after the static scene has been rendered once: a scene whose targets all stand still, and
// one with moving people and cars (whose pixels are re-rendered every frame).
// Run: build/bin/bench_sim  (the live source needs under 20 ms per frame set for 50 Hz)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <map>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <string>

#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

const thermovis::sim::SimulatedRig& simulator(const std::string& scene_name) {
  static std::map<std::string, std::unique_ptr<thermovis::sim::SimulatedRig>> cache;
  auto& sim = cache[scene_name];
  if (!sim) {
    const auto root = thermovis::test::source_root();
    sim = std::make_unique<thermovis::sim::SimulatedRig>(
        thermovis::runtime::load_rig(root / "deploy/rigs/paper.yaml"),
        thermovis::runtime::load_scene(root / "deploy/scenes" / (scene_name + ".yaml")), 1);
  }
  return *sim;
}

void render_scene(benchmark::State& state, const std::string& scene_name) {
  const auto& sim = simulator(scene_name);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);  // render() is single-threaded; keep OpenCV's helpers on one core too
  thermovis::sim::FrameSet frames = sim.allocate();
  std::int64_t frame = 0;
  for (auto _ : state) {
    sim.render(frame, frames);
    benchmark::DoNotOptimize(frames.images[0].data);
    frame = (frame + 1) % 500;  // 10 s of motion, then again
  }
  cv::setNumThreads(threads);
  // Pixels re-rendered per frame set, over the frames the loop rendered (outside the timing).
  std::int64_t dynamic_pixels = 0;
  const std::int64_t rendered = std::min<std::int64_t>(state.iterations(), 500);
  for (std::int64_t k = 0; k < rendered; ++k) dynamic_pixels += sim.dynamic_pixel_count(k);
  state.counters["dynamic_px_per_frame"] = static_cast<double>(dynamic_pixels) /
                                           static_cast<double>(std::max<std::int64_t>(1, rendered));
  state.counters["frame_sets_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_FrameSet_StaticScene(benchmark::State& state) { render_scene(state, "paper"); }
void BM_FrameSet_MovingTargets(benchmark::State& state) { render_scene(state, "street"); }
void BM_FrameSet_NightMovingTarget(benchmark::State& state) { render_scene(state, "night"); }

BENCHMARK(BM_FrameSet_StaticScene)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrameSet_MovingTargets)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FrameSet_NightMovingTarget)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
