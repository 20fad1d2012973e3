// CPU cost of the detection stage per frame, one thread, on the pipeline's grid (the visible
// pair grid at --grid-scale 0.5: 936 x 566): a simulated capture of the paper scene, its left
// infrared camera (16-bit raw counts) rectified onto that grid, people searched with the grid's
// ground prior. The infrared detectors: the trained classifier (shipped model) and the
// simulator-tuned warm blobs; each on the raw counts and on the same frame made 8-bit. Also the
// classifier's HOGs two ways (BM_CandidateHogs) and connected components two ways.
// Run: build/bin/bench_detect  (the machine is shared: absolute times move with the load)
#include <benchmark/benchmark.h>

#include <chrono>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <vector>

#include "thermovis/detect/detectors.hpp"
#include "thermovis/detect/infrared_classifier.hpp"
#include "thermovis/detect/person_detector.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/rectify/stereo_geometry.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

using namespace thermovis;

struct Frame {
  cv::Mat raw, eight_bit;  // rectified infrared, CV_16UC1 counts and CV_8UC1
  std::unique_ptr<camera::RectifiedCamera> grid;
};

const Frame& frame() {
  static std::unique_ptr<Frame> f;
  if (f) return *f;
  const auto root = test::source_root();
  const camera::Rig rig = runtime::load_rig(root / "deploy/rigs/paper.yaml");
  const sim::SimulatedRig simulator(rig, runtime::load_scene(root / "deploy/scenes/paper.yaml"), 1);
  sim::FrameSet raw = simulator.allocate();
  simulator.render(0, raw);
  const auto grid = camera::scaled(
      rectify::default_pair_grid(rig, rig.visible, camera::RectifiedProjection::equirectangular),
      0.5);
  const auto geometry = rectify::make_stereo_geometry(rig, rig.visible, grid);
  const auto& cam = rig.camera(rig.infrared.left);
  const fpga::FastRemapper remapper(fpga::FixedPointMap::from_float(
      rectify::build_map(cam, geometry.T_ref_left_rect, geometry.grid, 0.0),
      cam.model->image_size()));
  f = std::make_unique<Frame>();
  remapper.remap(raw[sim::Slot::infrared_left], f->raw);
  f->eight_bit = detect::infrared_to_8bit(f->raw);
  f->grid = std::make_unique<camera::RectifiedCamera>(geometry.grid);
  return *f;
}

void run(benchmark::State& state, bool classifier, bool eight_bit) {
  const Frame& f = frame();
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  detect::PersonDetectorOptions o;
  if (classifier) o.infrared_model = test::source_root() / "deploy/models/person_ir.yml.gz";
  detect::PersonDetector detector(o);
  std::size_t found = 0;
  for (auto _ : state) {
    found = detector.detect(eight_bit ? f.eight_bit : f.raw, cv::Mat(), f.grid.get()).size();
  }
  cv::setNumThreads(threads);
  state.counters["grid_w"] = f.raw.cols;
  state.counters["grid_h"] = f.raw.rows;
  state.counters["boxes"] = static_cast<double>(found);
}

void BM_ClassifierRaw(benchmark::State& state) { run(state, true, false); }
void BM_Classifier8bit(benchmark::State& state) { run(state, true, true); }
void BM_WarmBlobsRaw(benchmark::State& state) { run(state, false, false); }
void BM_WarmBlobs8bit(benchmark::State& state) { run(state, false, true); }

// Connected components of the frame's warm-blob mask (detect::warm_blob_mask): ours
// (detect::label_components) against OpenCV's connectedComponentsWithStats, one thread.
const cv::Mat& blob_mask() {
  static const cv::Mat mask = detect::warm_blob_mask(frame().raw, {}).mask;
  return mask;
}

void BM_Components(benchmark::State& state) {
  const cv::Mat& mask = blob_mask();
  const bool ours = state.range(0) == 1;
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  cv::Mat labels, stats, centroids;
  std::size_t found = 0;
  for (auto _ : state) {
    if (ours) {
      found = detect::label_components(mask, labels).size();
    } else {
      found = static_cast<std::size_t>(
                  cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S)) -
              1;
    }
  }
  cv::setNumThreads(threads);
  state.SetLabel(ours ? "ours" : "opencv");
  state.counters["components"] = static_cast<double>(found);
  state.counters["set_pixels"] = cv::countNonZero(mask);
}

// The HOG descriptors of the classifier's candidate windows (the frame's candidates, each box
// shrunk to the 20 x 20 window): one cv::HOGDescriptor::compute per window (OpenCV's way) against
// detect::HogMosaic (one call over the framed windows), both in every iteration, one thread.
// Counters: each way's ms per frame and opencv_over_ours, the ratio in the same run.
void BM_CandidateHogs(benchmark::State& state) {
  const cv::Mat& ir8 = frame().eight_bit;
  const cv::HOGDescriptor hog = detect::classifier_hog();
  std::vector<cv::Mat> windows;
  for (const detect::Candidate& c : detect::infrared_candidates(ir8)) {
    cv::Mat w;
    cv::resize(ir8(c.box), w, hog.winSize, 0, 0, cv::INTER_AREA);
    windows.push_back(w);
  }
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  using clock = std::chrono::steady_clock;
  clock::duration opencv{}, ours{};
  std::vector<float> one, all;
  for (auto _ : state) {
    const auto t0 = clock::now();
    for (const cv::Mat& w : windows) hog.compute(w, one);
    const auto t1 = clock::now();
    detect::HogMosaic mosaic(hog, static_cast<int>(windows.size()));
    for (std::size_t i = 0; i < windows.size(); ++i) {
      windows[i].copyTo(mosaic.scratch());
      mosaic.set(static_cast<int>(i));
    }
    all = mosaic.compute();
    const auto t2 = clock::now();
    opencv += t1 - t0;
    ours += t2 - t1;
    benchmark::DoNotOptimize(all.data());
  }
  cv::setNumThreads(threads);
  const auto ms = [&](clock::duration d) {
    return std::chrono::duration<double, std::milli>(d).count() /
           static_cast<double>(state.iterations());
  };
  state.counters["windows"] = static_cast<double>(windows.size());
  state.counters["opencv_ms"] = ms(opencv);
  state.counters["ours_ms"] = ms(ours);
  state.counters["opencv_over_ours"] = ms(opencv) / ms(ours);
}

BENCHMARK(BM_Components)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_CandidateHogs)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_ClassifierRaw)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_Classifier8bit)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_WarmBlobsRaw)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();
BENCHMARK(BM_WarmBlobs8bit)->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime();

}  // namespace

BENCHMARK_MAIN();
