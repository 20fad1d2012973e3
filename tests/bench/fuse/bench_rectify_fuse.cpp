// CPU cost of thermovis-rectify-fuse's work for one capture, stage by stage, on one thread, on
// a simulated capture of the paper scene and the pipeline's grid (--grid-scale 0.5 by default;
// THERMOVIS_BENCH_GRID_SCALE overrides): the fixed-point remap of the two infrared cameras
// (16-bit raw counts) and the two visible cameras (BGR) onto the visible eyes' grids, then per
// eye the infrared AGC, the visible contrast enhancement and the fusion.
// Run: build/bin/bench_rectify_fuse  (compare the stages' CPU times in one run; the machine is
// shared: absolute times move with the load)
#include <benchmark/benchmark.h>

#include <array>
#include <cstdlib>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <optional>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/fuse/fusion.hpp"
#include "thermovis/rectify/stereo_geometry.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

using namespace thermovis;
using sim::Slot;

// The service's settings (RectifyFuseConfig): fast fusion of the luma, the visible contrast
// enhancement done on the same luma.
fuse::FusionOptions pipeline_fusion() {
  return {
      fuse::FusionMethod::fast, fuse::ColourMode::luminance, {}, enhance::VisibleContrastParams{}};
}

// The same without the enhancement (the visible image enhanced beforehand, as a colour image).
fuse::FusionOptions plain_fusion() {
  return {fuse::FusionMethod::fast, fuse::ColourMode::luminance, {}, std::nullopt};
}

struct Capture {
  sim::FrameSet raw;
  std::array<std::unique_ptr<fpga::FastRemapper>, 2> visible_maps, infrared_maps;
  std::array<cv::Mat, 2> rect_visible, rect_infrared;
  cv::Mat agc_infrared;  // rect_infrared[0] through the service's AGC: what fusion takes

  // One band's pair onto the grid through its fixed-point maps, as the service does per capture.
  void remap_infrared() {
    infrared_maps[0]->remap(raw[Slot::infrared_left], rect_infrared[0]);
    infrared_maps[1]->remap(raw[Slot::infrared_right], rect_infrared[1]);
  }
  void remap_visible() {
    visible_maps[0]->remap(raw[Slot::visible_left], rect_visible[0]);
    visible_maps[1]->remap(raw[Slot::visible_right], rect_visible[1]);
  }
};

Capture& capture() {
  static std::unique_ptr<Capture> c;
  if (c) return *c;
  const auto root = test::source_root();
  const camera::Rig rig = runtime::load_rig(root / "deploy/rigs/paper.yaml");
  const sim::SimulatedRig simulator(rig, runtime::load_scene(root / "deploy/scenes/paper.yaml"), 1);
  c = std::make_unique<Capture>();
  c->raw = simulator.allocate();
  simulator.render(3, c->raw);
  const char* scale_env = std::getenv("THERMOVIS_BENCH_GRID_SCALE");
  const double scale = scale_env != nullptr ? std::atof(scale_env) : 0.5;
  const auto grid = camera::scaled(
      rectify::default_pair_grid(rig, rig.visible, camera::RectifiedProjection::equirectangular),
      scale);
  const auto geometry = rectify::make_stereo_geometry(rig, rig.visible, grid);
  const auto remapper = [&](const std::string& name, const Eigen::Isometry3d& T_ref_rect) {
    const auto& cam = rig.camera(name);
    return std::make_unique<fpga::FastRemapper>(fpga::FixedPointMap::from_float(
        rectify::build_map(cam, T_ref_rect, geometry.grid, 0.0), cam.model->image_size()));
  };
  c->visible_maps = {remapper(rig.visible.left, geometry.T_ref_left_rect),
                     remapper(rig.visible.right, geometry.T_ref_right_rect)};
  c->infrared_maps = {remapper(rig.infrared.left, geometry.T_ref_left_rect),
                      remapper(rig.infrared.right, geometry.T_ref_right_rect)};
  c->remap_visible();
  c->remap_infrared();
  c->agc_infrared = enhance::InfraredAgc().process(c->rect_infrared[0]);
  return *c;
}

// Each benchmark runs with OpenCV on one thread, as the services do.
struct OneThread {
  int before = cv::getNumThreads();
  OneThread() { cv::setNumThreads(1); }
  ~OneThread() { cv::setNumThreads(before); }
};

void set_grid_counters(benchmark::State& state) {
  const cv::Size s = capture().rect_visible[0].size();
  state.counters["grid_w"] = s.width;
  state.counters["grid_h"] = s.height;
}

void BM_RemapInfraredPair(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  for (auto _ : state) c.remap_infrared();
  set_grid_counters(state);
}

void BM_RemapVisiblePair(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  for (auto _ : state) c.remap_visible();
}

void BM_InfraredAgcEye(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  enhance::InfraredAgc agc;
  for (auto _ : state) benchmark::DoNotOptimize(agc.process(c.rect_infrared[0]).data);
}

void BM_VisibleEnhanceEye(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  for (auto _ : state) benchmark::DoNotOptimize(enhance::enhance_visible(c.rect_visible[0]).data);
}

// Fusion of one eye with the enhancement inside (the service's way)...
void BM_EnhanceAndFuseEye(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  cv::Mat fused;
  for (auto _ : state) fuse::fuse(c.agc_infrared, c.rect_visible[0], fused, pipeline_fusion());
}

// ... and enhancing the colour image first, then fusing it.
void BM_EnhanceThenFuseEye(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  cv::Mat fused;
  for (auto _ : state) {
    fuse::fuse(c.agc_infrared, enhance::enhance_visible(c.rect_visible[0]), fused, plain_fusion());
  }
}

// The whole per-capture work of the service on one thread: both pairs rectified, `eyes` eyes
// fused (1: the service's default, the display's left eye; 2: --fused-eyes both).
void BM_Capture(benchmark::State& state) {
  Capture& c = capture();
  const OneThread one;
  const int eyes = static_cast<int>(state.range(0));
  std::array<enhance::InfraredAgc, 2> agc;
  std::array<cv::Mat, 2> fused;
  for (auto _ : state) {
    c.remap_infrared();
    c.remap_visible();
    for (int i = 0; i < eyes; ++i) {
      fuse::fuse(agc[i].process(c.rect_infrared[i]), c.rect_visible[i], fused[i],
                 pipeline_fusion());
    }
  }
  set_grid_counters(state);
}

BENCHMARK(BM_RemapInfraredPair)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_RemapVisiblePair)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_InfraredAgcEye)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_VisibleEnhanceEye)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_EnhanceAndFuseEye)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_EnhanceThenFuseEye)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_Capture)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
