// Per-stage timings of enhancement and fusion on one core (cv::setNumThreads(1)), at the rig's
// infrared (1024x768) and visible (1920x1080) sizes, on seeded synthetic frames. After the runs,
// the ratio between the fusion modes at each size is printed from the same run's CPU times.
//   bench_fuse [--benchmark_filter=...]
#include <benchmark/benchmark.h>

#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fuse/fusion.hpp"

namespace {

namespace fu = thermovis::fuse;
namespace en = thermovis::enhance;

cv::Size size_of(const benchmark::State& state) {
  return {static_cast<int>(state.range(0)), static_cast<int>(state.range(1))};
}

// A scene-like frame: smooth background, a few warm blobs and edges, sensor noise.
cv::Mat synthetic(cv::Size size, int type, double lo, double hi, unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat f(size, CV_32F);
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      f.at<float>(r, c) =
          static_cast<float>(0.3 + 0.4 * r / size.height + 0.1 * std::sin(c * 0.02));
    }
  }
  for (int i = 0; i < 12; ++i) {
    cv::Point p(rng.uniform(0, size.width), rng.uniform(0, size.height));
    cv::circle(f, p, rng.uniform(10, size.width / 8), cv::Scalar(rng.uniform(0.0, 1.0)), -1);
    cv::rectangle(f, cv::Rect(rng.uniform(0, size.width), rng.uniform(0, size.height), 60, 30),
                  cv::Scalar(rng.uniform(0.0, 1.0)), 2);
  }
  cv::GaussianBlur(f, f, cv::Size(0, 0), 1.5);
  cv::Mat noise(size, CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 0.01);
  f += noise;
  cv::Mat out;
  f.convertTo(out, CV_MAKETYPE(CV_MAT_DEPTH(type), 1), hi - lo, lo);
  if (CV_MAT_CN(type) == 3) {
    cv::Mat g = out, b, r;
    cv::add(out, cv::Scalar(10), b);
    cv::subtract(out, cv::Scalar(10), r);
    cv::merge(std::vector<cv::Mat>{b, g, r}, out);
  }
  return out;
}

void BM_InfraredAgc16(benchmark::State& state) {
  const cv::Mat raw = synthetic(size_of(state), CV_16UC1, 7000, 9000, 1);
  en::InfraredAgc agc;
  for (auto _ : state) benchmark::DoNotOptimize(agc.process(raw).data);
}

void BM_InfraredAgc8(benchmark::State& state) {
  const cv::Mat raw = synthetic(size_of(state), CV_8UC1, 20, 230, 1);
  en::InfraredAgc agc;
  for (auto _ : state) benchmark::DoNotOptimize(agc.process(raw).data);
}

void BM_VisibleContrast(benchmark::State& state) {
  const cv::Mat vis = synthetic(size_of(state), CV_8UC3, 10, 240, 2);
  for (auto _ : state) benchmark::DoNotOptimize(en::enhance_visible(vis).data);
}

template <fu::FusionMethod kMethod, fu::ColourMode kColour, int kScale = 0>
void BM_Fusion(benchmark::State& state) {
  const cv::Mat ir = synthetic(size_of(state), CV_8UC1, 20, 230, 3);
  const cv::Mat vis = synthetic(size_of(state), CV_8UC3, 10, 240, 4);
  fu::FusionOptions o;
  o.method = kMethod;
  o.colour = kColour;
  if (kScale > 0) o.fast.scale = kScale;
  cv::Mat fused;  // reused from frame to frame, as in the pipeline
  for (auto _ : state) {
    fu::fuse(ir, vis, fused, o);
    benchmark::DoNotOptimize(fused.data);
  }
}

void sizes(benchmark::internal::Benchmark* b) {
  b->Args({1024, 768})->Args({1920, 1080})->Unit(benchmark::kMillisecond);
}

BENCHMARK(BM_InfraredAgc16)->Apply(sizes);
BENCHMARK(BM_InfraredAgc8)->Apply(sizes);
BENCHMARK(BM_VisibleContrast)->Apply(sizes);
BENCHMARK_TEMPLATE(BM_Fusion, fu::FusionMethod::fast, fu::ColourMode::luminance)->Apply(sizes);
BENCHMARK_TEMPLATE(BM_Fusion, fu::FusionMethod::fast, fu::ColourMode::luminance, 4)->Apply(sizes);
BENCHMARK_TEMPLATE(BM_Fusion, fu::FusionMethod::fast, fu::ColourMode::per_channel)->Apply(sizes);
BENCHMARK_TEMPLATE(BM_Fusion, fu::FusionMethod::vsmwls, fu::ColourMode::luminance)->Apply(sizes);
BENCHMARK_TEMPLATE(BM_Fusion, fu::FusionMethod::vsmwls, fu::ColourMode::per_channel)->Apply(sizes);

// Keeps each run's time per iteration (ms) to print the ratios between fusion modes.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& run : runs) {
      if (run.run_type == Run::RT_Iteration || run.aggregate_name == "mean") {
        ms_[run.benchmark_name()] = run.GetAdjustedCPUTime();  // CPU: the machine may be shared
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void PrintRatios() const {
    for (const char* size : {"1024/768", "1920/1080"}) {
      const auto find = [&](const std::string& prefix) {
        const auto it = ms_.find(prefix + "/" + size);
        return it == ms_.end() ? -1.0 : it->second;
      };
      const double fast = find("BM_Fusion<fu::FusionMethod::fast, fu::ColourMode::luminance>");
      const double ref = find("BM_Fusion<fu::FusionMethod::vsmwls, fu::ColourMode::luminance>");
      const double fast3 = find("BM_Fusion<fu::FusionMethod::fast, fu::ColourMode::per_channel>");
      const double ref3 = find("BM_Fusion<fu::FusionMethod::vsmwls, fu::ColourMode::per_channel>");
      if (fast > 0 && ref > 0) {
        std::cout << std::fixed << std::setprecision(2) << size << ": luminance fusion vsmwls "
                  << ref << " ms / fast " << fast << " ms = " << std::setprecision(0) << ref / fast
                  << "x\n";
      }
      if (fast3 > 0 && ref3 > 0) {
        std::cout << std::fixed << std::setprecision(2) << size << ": per-channel fusion vsmwls "
                  << ref3 << " ms / fast " << fast3 << " ms = " << std::setprecision(0)
                  << ref3 / fast3 << "x\n";
      }
    }
  }

 private:
  std::map<std::string, double> ms_;
};

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core, as the per-stage budget is stated
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.PrintRatios();
  benchmark::Shutdown();
  return 0;
}
