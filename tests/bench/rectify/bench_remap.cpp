// Remap speed: our fixed-point table (fpga::FastRemapper: the Highway kernel over a layout
// precomputed from the Q11.5 table) against cv::remap with the float maps (CV_32FC2), in the
// same run, on the paper rig's maps:
//   visible 1920x1080 8-bit BGR and infrared 1024x768 16-bit raw, each through the paper's
//   elliptical correction (output = input size) and the Taylor rectification (output = the
//   pair's rectified grid).
// Counters: table sizes in bytes (full Q11.5 table, quarter table where the map is symmetric,
// float map, FastRemapper's layout); BM_Compare reports float_over_ours = time(float) /
// time(ours) measured alternately in one loop (>= 1: ours at least as fast).
#include <benchmark/benchmark.h>

#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/rectify/elliptical.hpp"
#include "thermovis/rectify/rig_rectification.hpp"
#include "thermovis/test/compare_alternately.hpp"
#include "thermovis/test/paper_rig.hpp"

namespace {

using namespace thermovis;

struct Case {
  cv::Mat image;      // seeded random input
  cv::Mat float_map;  // CV_32FC2
  fpga::FixedPointMap table;
  std::unique_ptr<fpga::FastRemapper> fast;
  std::size_t quarter_bytes = 0;  // 0 when the map is not symmetric
};

// 0: visible elliptical, 1: infrared elliptical, 2: visible Taylor rectified, 3: infrared Taylor.
const Case& get_case(int index) {
  static std::map<int, Case> cases;
  auto it = cases.find(index);
  if (it != cases.end()) return it->second;
  const camera::Rig& rig = test::paper_rig();
  const bool infrared = index % 2 == 1;
  const auto& cam = rig.camera(infrared ? rig.infrared.left : rig.visible.left);
  Case c;
  if (index < 2) {
    c.float_map = rectify::build_elliptical_map(
        rectify::fit_elliptical_model(dynamic_cast<const camera::TaylorCamera&>(*cam.model)).model);
  } else {
    c.float_map = rectify::rectify_pair(rig, infrared ? rig.infrared : rig.visible,
                                        camera::RectifiedProjection::equirectangular)
                      .left_map;
  }
  const cv::Size size = cam.model->image_size();
  c.image = cv::Mat(size, infrared ? CV_16UC1 : CV_8UC3);
  cv::RNG(42).fill(c.image, cv::RNG::UNIFORM, 0, infrared ? (1 << 14) : 256);
  c.table = fpga::FixedPointMap::from_float(c.float_map, size);
  c.fast = std::make_unique<fpga::FastRemapper>(c.table);
  if (fpga::check_quarter_symmetry(c.table).symmetric) {
    c.quarter_bytes = fpga::QuarterTable::from_map(c.table).table_bytes();
  }
  return cases.emplace(index, std::move(c)).first->second;
}

const char* case_name(int index) {
  static const char* names[] = {
      "visible_1920x1080_bgr8_elliptical", "infrared_1024x768_raw16_elliptical",
      "visible_1920x1080_bgr8_rectified", "infrared_1024x768_raw16_rectified"};
  return names[index];
}

void set_counters(benchmark::State& state, const Case& c) {
  state.SetLabel(case_name(static_cast<int>(state.range(0))));
  state.counters["out_px"] = static_cast<double>(c.table.size().area());
  state.counters["table_bytes"] = static_cast<double>(c.table.table_bytes());
  state.counters["quarter_bytes"] = static_cast<double>(c.quarter_bytes);
  state.counters["float_map_bytes"] =
      static_cast<double>(c.float_map.total() * c.float_map.elemSize());
  state.counters["fast_map_bytes"] = static_cast<double>(c.fast->map_bytes());
}

void BM_RemapOurs(benchmark::State& state) {
  const Case& c = get_case(static_cast<int>(state.range(0)));
  cv::Mat out;
  for (auto _ : state) {
    c.fast->remap(c.image, out);
    benchmark::DoNotOptimize(out.data);
  }
  set_counters(state, c);
}

void BM_RemapOpenCvFloat(benchmark::State& state) {
  const Case& c = get_case(static_cast<int>(state.range(0)));
  cv::Mat out;
  for (auto _ : state) {
    cv::remap(c.image, out, c.float_map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    benchmark::DoNotOptimize(out.data);
  }
  set_counters(state, c);
}

void BM_Compare(benchmark::State& state) {
  const Case& c = get_case(static_cast<int>(state.range(0)));
  cv::Mat out;
  test::compare_alternately(
      state, "float", [&] { c.fast->remap(c.image, out); },
      [&] {
        cv::remap(c.image, out, c.float_map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
        benchmark::DoNotOptimize(out.data);
      });
  set_counters(state, c);
}

// The bit-exact model (one pixel at a time, as the hardware): for reference, not speed.
void BM_RemapBitExactModel(benchmark::State& state) {
  const Case& c = get_case(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    cv::Mat out = fpga::remap_reference(c.image, c.table);
    benchmark::DoNotOptimize(out.data);
  }
  set_counters(state, c);
}

BENCHMARK(BM_RemapOurs)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RemapOpenCvFloat)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Compare)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RemapBitExactModel)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
