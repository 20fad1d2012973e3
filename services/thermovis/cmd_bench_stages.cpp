// thermovis bench stages: the pipeline's four stages in one process on the simulated rig, one
// capture after another, with the stage classes and the geometry the services run: CPU time of
// each stage per capture, beside a floor measured in the same run (one copy of every image of a
// capture and cv::resize(INTER_AREA) of each to the grid), and the ranges matched to the
// simulated truth per person (the figures `bench pipeline` gives for the separate processes).
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "capture_floor.hpp"
#include "command.hpp"
#include "scene_arg.hpp"
#include "thermovis/metrics/percentile.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/grid_options.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "truth_match.hpp"

namespace {

namespace pl = thermovis::pipeline;
namespace sim = thermovis::sim;

struct Options {
  std::string rig;
  std::string scene = "paper";
  int frames = 50;
  int warmup = 3;
  std::string band = "both";
  std::uint64_t seed = 1;
  bool json = false;
  pl::GridOptions grid;
};

using thermovis::cli::thread_cpu_ms;

// CPU time of one stage over the captures measured.
struct StageTime {
  std::vector<double> ms;
  double mean() const {
    double s = 0;
    for (double v : ms) s += v;
    return ms.empty() ? 0.0 : s / static_cast<double>(ms.size());
  }
  double percentile(double p) const { return thermovis::metrics::percentile(ms, p); }
};

struct PerTarget {
  double truth_sum = 0, error_sum = 0, abs_error_sum = 0, sigma_sum = 0;
  int ranges = 0;
  int within_sigma = 0;
};

int run_bench_stages(const Options& opt) {
  if (opt.frames < 1) throw std::invalid_argument("--frames must be >= 1");
  if (opt.warmup < 0) throw std::invalid_argument("--warmup must be >= 0");
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  const sim::Scene scene = thermovis::runtime::load_scene(thermovis::cli::resolve_scene(opt.scene));
  const sim::SimulatedRig simulated(rig, scene, opt.seed);
  pl::CapturePipelineOptions options;
  options.grid = opt.grid;
  options.fuse = true;  // the display's fused left image, as rectify-fuse makes it
  const pl::BandChoice band = pl::parse_band_choice(opt.band);
  pl::CapturePipeline pipeline(rig, options);
  const cv::Size grid = pipeline.geometry().grid_size();

  const std::vector<std::string> stage_names = {"rectify_infrared", "rectify_visible", "fuse",
                                                "detect",           "match",           "range"};
  std::map<std::string, StageTime> times;
  StageTime total, floor;
  std::map<std::string, PerTarget> per;
  int detections = 0, ranged = 0, matched = 0;
  sim::FrameSet frames = simulated.allocate();
  pl::GridCapture capture;
  for (int frame = 0; frame < opt.warmup + opt.frames; ++frame) {
    simulated.render(frame, frames);
    const bool measured = frame >= opt.warmup;
    std::map<std::string, double> ms;
    // Each stage on this thread alone (this thread's CPU time would leave out OpenCV's workers':
    // the remaps share their rows among them); the rendering keeps them.
    auto timed = [&](const std::string& name, const auto& body) {
      const thermovis::cli::OneOpenCvThread one_thread;
      const double t0 = thread_cpu_ms();
      body();
      ms[name] += thread_cpu_ms() - t0;
    };
    auto& stage = pipeline.rectify_stage();
    timed("rectify_infrared", [&] {
      stage.rectify_infrared(pl::Eye::left, frames[sim::Slot::infrared_left],
                             capture.infrared_left);
      stage.rectify_infrared(pl::Eye::right, frames[sim::Slot::infrared_right],
                             capture.infrared_right);
    });
    timed("rectify_visible", [&] {
      stage.rectify_visible(pl::Eye::left, frames[sim::Slot::visible_left], capture.visible_left);
      stage.rectify_visible(pl::Eye::right, frames[sim::Slot::visible_right],
                            capture.visible_right);
    });
    timed("fuse", [&] {
      stage.fuse(pl::Eye::left, capture.infrared_left,
                 stage.fusion_visible(pl::Eye::left, capture.visible_left,
                                      frames[sim::Slot::visible_left]),
                 capture.fused_left);
    });
    std::vector<thermovis::detect::Detection> found;
    timed("detect", [&] { found = pipeline.detect(capture); });
    // The match service's own view of the visible pair: grey copies of the received frames.
    timed("match", [&] {
      capture.grey_left = pl::MatchStage::stage_grey(capture.visible_left);
      capture.grey_right = pl::MatchStage::stage_grey(capture.visible_right);
    });
    const pl::MatchImages images{
        capture.grey_left, capture.grey_right, capture.infrared_left, capture.infrared_right, {}};
    const auto truths = simulated.truth(frame);
    for (const auto& d : found) {
      std::vector<pl::BandMatches> bands;
      timed("match", [&] { bands = pipeline.match_stage(band).match(images, d.box, d.cls); });
      std::vector<pl::TargetEntry> entries;
      for (const auto& b : bands)
        entries.push_back({b.band, d.cls, d.box, b.result.matches, b.result.region});
      if (entries.empty()) continue;
      pl::RangedTarget r;
      timed("range", [&] { r = pipeline.range_stage().range(entries); });
      if (!measured) continue;
      ++detections;
      if (!r.ok()) continue;
      ++ranged;
      const auto truth = thermovis::cli::truth_on_line_of_sight(truths, r.position_m);
      if (!truth) continue;
      ++matched;
      PerTarget& t = per[truth->id];
      const double error = r.distance_m - truth->distance_m;
      t.truth_sum += truth->distance_m;
      t.error_sum += error;
      t.abs_error_sum += std::abs(error);
      t.sigma_sum += r.range.sigma_m;
      t.within_sigma += std::abs(error) <= r.range.sigma_m;
      ++t.ranges;
    }
    // The floor: one copy of every image of the capture, and each resized to its band's grid.
    const double floor_ms = thermovis::cli::capture_floor_cpu_ms(
        frames.images, grid, pipeline.geometry().image_size(pl::Band::infrared), 1);
    if (!measured) continue;
    double sum = 0;
    for (const auto& name : stage_names) {
      times[name].ms.push_back(ms[name]);
      sum += ms[name];
    }
    total.ms.push_back(sum);
    floor.ms.push_back(floor_ms);
  }

  std::vector<std::pair<std::string, double>> targets;  // id, mean truth (sorted by distance)
  for (const auto& [id, t] : per) targets.emplace_back(id, t.truth_sum / t.ranges);
  std::sort(targets.begin(), targets.end(),
            [](const auto& a, const auto& b) { return a.second < b.second; });
  if (opt.json) {
    nlohmann::json stages = nlohmann::json::object();
    for (const auto& name : stage_names) {
      stages[name] = {{"cpu_ms_mean", times[name].mean()},
                      {"cpu_ms_p95", times[name].percentile(95)}};
    }
    nlohmann::json people = nlohmann::json::array();
    for (const auto& [id, truth_m] : targets) {
      const PerTarget& t = per[id];
      people.push_back({{"id", id},
                        {"truth_m", truth_m},
                        {"ranges", t.ranges},
                        {"mean_error_m", t.error_sum / t.ranges},
                        {"mean_abs_error_m", t.abs_error_sum / t.ranges},
                        {"mean_sigma_m", t.sigma_sum / t.ranges},
                        {"within_1_sigma", static_cast<double>(t.within_sigma) / t.ranges}});
    }
    std::cout << nlohmann::json{{"scene", opt.scene},
                                {"grid", {grid.width, grid.height}},
                                {"frames", opt.frames},
                                {"band", opt.band},
                                {"stages", stages},
                                {"total_cpu_ms_mean", total.mean()},
                                {"total_cpu_ms_p95", total.percentile(95)},
                                {"floor_cpu_ms_mean", floor.mean()},
                                {"detections", detections},
                                {"ranged", ranged},
                                {"matched_to_truth", matched},
                                {"targets", people}}
                     .dump()
              << "\n";
    return 0;
  }
  std::cout << "Stages in one process, scene " << opt.scene << ", grid " << grid.width << "x"
            << grid.height << ", " << opt.frames << " captures, band " << opt.band << "\n"
            << std::fixed << std::setprecision(2);
  std::cout << std::setw(18) << "stage" << std::setw(12) << "CPU ms" << std::setw(10) << "p95"
            << "\n";
  for (const auto& name : stage_names) {
    std::cout << std::setw(18) << name << std::setw(12) << times[name].mean() << std::setw(10)
              << times[name].percentile(95) << "\n";
  }
  std::cout << std::setw(18) << "total" << std::setw(12) << total.mean() << std::setw(10)
            << total.percentile(95) << "\n"
            << std::setw(18) << "floor" << std::setw(12) << floor.mean()
            << "   (copy + INTER_AREA resize of the 4 images; total = " << std::setprecision(1)
            << total.mean() / std::max(1e-9, floor.mean()) << " x floor)\n";
  std::cout << "detections " << detections << ", ranged " << ranged << ", on a simulated target "
            << matched << "\n"
            << std::setprecision(3);
  for (const auto& [id, truth_m] : targets) {
    const PerTarget& t = per[id];
    std::cout << "  " << std::setw(10) << id << "  truth " << std::setw(6) << std::setprecision(2)
              << truth_m << " m  ranges " << std::setw(5) << t.ranges << "  mean error "
              << std::showpos << std::setprecision(3) << t.error_sum / t.ranges << std::noshowpos
              << " m  mean sigma " << t.sigma_sum / t.ranges << " m  in 1 sigma "
              << std::setprecision(2) << static_cast<double>(t.within_sigma) / t.ranges << "\n";
  }
  return 0;
}

THERMOVIS_COMMAND(
    "bench stages",
    "The pipeline's stages in one process on the simulated rig: CPU per stage and "
    "capture, and ranges against the truth per person",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--scene", opt->scene, "shipped scene name or scene YAML")
          ->capture_default_str();
      app.add_option("--frames", opt->frames, "captures measured")->capture_default_str();
      app.add_option("--warmup", opt->warmup, "captures before the measurement")
          ->capture_default_str();
      app.add_option("--band", opt->band, "both | auto | visible | infrared")
          ->capture_default_str();
      app.add_option("--seed", opt->seed, "noise seed")->capture_default_str();
      app.add_flag("--json", opt->json, "one JSON object");
      thermovis::runtime::add_grid_options(app, opt->grid);
      return [opt] { return run_bench_stages(*opt); };
    });

}  // namespace
