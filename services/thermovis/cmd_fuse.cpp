// thermovis fuse / fuse-eval: infrared/visible fusion of one pair, and evaluation of a method on a
// folder of pairs (laid out like VIFB: IR/<name>.<ext>, VI/<name>.<ext>) with VIFB's metrics.
#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/enhance/infrared_agc.hpp"
#include "thermovis/enhance/visible_contrast.hpp"
#include "thermovis/fuse/fusion.hpp"
#include "thermovis/metrics/vifb_metrics.hpp"
#include "thermovis/metrics/vifb_tables.hpp"

namespace {

namespace fs = std::filesystem;
namespace fu = thermovis::fuse;
namespace vm = thermovis::metrics;
using Clock = std::chrono::steady_clock;

cv::Mat read_image(const fs::path& path, const char* what) {
  if (!fs::exists(path))
    throw std::runtime_error(std::string(what) + " image not found: " + path.string());
  cv::Mat m = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (m.empty())
    throw std::runtime_error("cannot decode " + std::string(what) + " image " + path.string());
  return m;
}

fu::FusionMethod parse_method(const std::string& name) {
  const auto m = fu::method_from_name(name);
  if (!m) throw std::runtime_error("unknown method '" + name + "' (vsmwls, vsmwls-paper, fast)");
  return *m;
}

fu::ColourMode parse_colour(const std::string& name) {
  const auto c = fu::colour_from_name(name);
  if (!c) throw std::runtime_error("unknown colour mode '" + name + "' (rgb, luminance)");
  return *c;
}

// The infrared image as fusion takes it. Raw detector counts (CV_16UC1, 14- or 16-bit: what a
// thermal camera and `thermovis scene render` give) always go through the pipeline's gain
// control (rectify-fuse's default AgcParams); 8-bit infrared only with `agc` (--enhance). An
// image stored as three equal channels is reduced to one first.
cv::Mat infrared_for_fusion(cv::Mat ir, bool agc) {
  if (ir.channels() == 3 && (agc || ir.depth() == CV_16U)) {
    cv::Mat plane;
    cv::extractChannel(ir, plane, 0);
    ir = plane;
  }
  if (agc || ir.depth() == CV_16U) ir = thermovis::enhance::InfraredAgc().process(ir);
  return ir;
}

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// ---------------------------------------------------------------- fuse
struct FuseOptions {
  std::string ir, vis, out, method = "vsmwls", colour = "rgb";
  int fast_scale = fu::FastFusionParams{}.scale;
  bool enhance = false, json = false;
};

int run_fuse(const FuseOptions& opt) {
  fu::FusionOptions options;
  options.method = parse_method(opt.method);
  options.colour = parse_colour(opt.colour);
  options.fast.scale = opt.fast_scale;
  cv::Mat ir = read_image(opt.ir, "infrared");
  cv::Mat vis = read_image(opt.vis, "visible");
  const auto start = Clock::now();
  ir = infrared_for_fusion(ir, opt.enhance);
  if (opt.enhance) vis = thermovis::enhance::enhance_visible(vis);
  const cv::Mat fused = fu::fuse(ir, vis, options);
  const double ms = ms_since(start);
  if (!cv::imwrite(opt.out, fused)) throw std::runtime_error("cannot write " + opt.out);
  if (opt.json) {
    std::cout << nlohmann::json{{"out", opt.out},       {"method", opt.method},
                                {"colour", opt.colour}, {"width", fused.cols},
                                {"height", fused.rows}, {"ms", ms}}
                     .dump()
              << "\n";
  } else {
    std::cout << "fused " << fused.cols << "x" << fused.rows << " (" << opt.method << ", "
              << opt.colour << ") in " << std::fixed << std::setprecision(1) << ms << " ms -> "
              << opt.out << "\n";
  }
  return 0;
}

// ---------------------------------------------------------------- fuse-eval
struct EvalOptions {
  std::string dir;
  std::vector<std::string> methods{"vsmwls"};
  std::string colour = "rgb";
  bool no_jpeg = false, json = false;
  std::string save;
  int fast_scale = fu::FastFusionParams{}.scale;
};

struct Pair {
  std::string name;
  fs::path ir, vis;
};

std::vector<Pair> find_pairs(const fs::path& dir) {
  if (!fs::is_directory(dir / "IR") || !fs::is_directory(dir / "VI")) {
    throw std::runtime_error(dir.string() + " must hold IR/ and VI/ folders");
  }
  std::map<std::string, fs::path> ir;
  for (const auto& e : fs::directory_iterator(dir / "IR")) {
    if (e.is_regular_file()) ir[e.path().stem().string()] = e.path();
  }
  std::vector<Pair> pairs;
  for (const auto& e : fs::directory_iterator(dir / "VI")) {
    if (!e.is_regular_file()) continue;
    const auto it = ir.find(e.path().stem().string());
    if (it != ir.end()) pairs.push_back({it->first, it->second, e.path()});
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.name < b.name; });
  if (pairs.empty())
    throw std::runtime_error("no IR/VI pairs with matching names in " + dir.string());
  return pairs;
}

struct MethodResult {
  std::string method;
  vm::MetricValues mean;
  double ms_per_pair = 0;
};

MethodResult evaluate(const std::vector<Pair>& pairs, const std::string& method,
                      const EvalOptions& opt) {
  fu::FusionOptions options;
  options.method = parse_method(method);
  options.colour = parse_colour(opt.colour);
  options.fast.scale = opt.fast_scale;
  MethodResult result{method, {}, 0.0};
  double total_ms = 0;
  for (const auto& pair : pairs) {
    const cv::Mat vis = read_image(pair.vis, "visible");
    // Raw counts are scored against their gain-controlled 8-bit view, the image that was fused.
    const cv::Mat ir = infrared_for_fusion(read_image(pair.ir, "infrared"), false);
    const auto start = Clock::now();
    const cv::Mat fused = fu::fuse(ir, vis, options);
    total_ms += ms_since(start);
    if (!opt.save.empty()) {
      fs::create_directories(opt.save);
      cv::imwrite((fs::path(opt.save) / (pair.name + "_" + method + ".png")).string(), fused);
    }
    const cv::Mat scored = opt.no_jpeg ? fused : vm::jpeg_round_trip(fused, 75);
    const auto values = vm::vifb_metrics(vis, ir, scored);
    for (auto m : vm::all_metrics())
      result.mean[m] += values[m] / static_cast<double>(pairs.size());
  }
  result.ms_per_pair = total_ms / static_cast<double>(pairs.size());
  return result;
}

// VIFB's row name for our method, where VIFB published one.
std::string vifb_row(const std::string& method) { return method == "vsmwls" ? "VSMWLS" : ""; }

int run_fuse_eval(const EvalOptions& opt) {
  const auto pairs = find_pairs(opt.dir);
  std::vector<MethodResult> results;
  for (const auto& method : opt.methods) results.push_back(evaluate(pairs, method, opt));

  std::map<std::string, vm::MetricValues> published;
  const fs::path table = fs::path(opt.dir) / "vifb_metrics_average.csv";
  if (fs::exists(table)) published = vm::load_vifb_averages(table);
  const std::string protocol =
      opt.no_jpeg ? "metrics on the 8-bit output (no JPEG step)"
                  : "VIFB protocol: metrics on the quality-75 JPEG of the output, per RGB channel";

  if (opt.json) {
    for (const auto& r : results) {
      nlohmann::json mean, vifb;
      for (auto m : vm::all_metrics()) mean[std::string(vm::metric_name(m))] = r.mean[m];
      nlohmann::json out{{"pairs", pairs.size()}, {"method", r.method},
                         {"colour", opt.colour},  {"protocol", protocol},
                         {"mean", mean},          {"ms_per_pair", r.ms_per_pair}};
      if (const auto it = published.find(vifb_row(r.method)); it != published.end()) {
        for (auto m : vm::all_metrics()) vifb[std::string(vm::metric_name(m))] = it->second[m];
        out["vifb"] = vifb;
      }
      std::cout << out.dump() << "\n";
    }
    return 0;
  }

  std::cout << pairs.size() << " pairs from " << opt.dir << "; colour " << opt.colour << "; "
            << protocol << "\n";
  std::ostringstream header;
  header << std::left << std::setw(6) << "metric" << std::right;
  for (const auto& r : results) header << std::setw(14) << r.method;
  const bool have_vsmwls = published.count("VSMWLS") > 0;
  if (have_vsmwls) header << std::setw(14) << "VIFB VSMWLS";
  if (!published.empty()) header << std::setw(24) << "VIFB best";
  std::cout << header.str() << "\n";
  for (auto m : vm::all_metrics()) {
    std::cout << std::left << std::setw(6) << vm::metric_name(m) << std::right;
    for (const auto& r : results)
      std::cout << std::setw(14) << std::setprecision(4) << std::fixed << r.mean[m];
    if (have_vsmwls) std::cout << std::setw(14) << published.at("VSMWLS")[m];
    if (!published.empty()) {
      const auto best =
          std::max_element(published.begin(), published.end(), [m](const auto& a, const auto& b) {
            return vm::higher_is_better(m) ? a.second[m] < b.second[m] : a.second[m] > b.second[m];
          });
      std::ostringstream cell;
      cell << std::setprecision(4) << std::fixed << best->second[m] << " (" << best->first << ")";
      std::cout << std::setw(24) << cell.str();
    }
    std::cout << (vm::higher_is_better(m) ? "  higher is better" : "  lower is better") << "\n";
  }
  std::cout << std::left << std::setw(6) << "ms" << std::right;
  for (const auto& r : results) std::cout << std::setw(14) << std::setprecision(2) << r.ms_per_pair;
  std::cout << "  fusion time per pair (this machine, all cores)\n";
  if (have_vsmwls) {
    for (const auto& r : results) {
      if (r.method != "vsmwls") continue;
      double worst = 0;
      for (auto m : vm::all_metrics()) {
        worst = std::max(worst, std::abs(r.mean[m] / published.at("VSMWLS")[m] - 1.0));
      }
      std::cout << "vsmwls vs VIFB VSMWLS: largest relative difference " << std::setprecision(3)
                << 100.0 * worst << " %\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND("fuse", "Fuse one registered infrared/visible pair into one image",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<FuseOptions>();
                    app.add_option("--ir", opt->ir,
                                   "infrared image: 8-bit, or raw 14/16-bit counts (16-bit PNG "
                                   "or TIFF), which get the pipeline's gain control")
                        ->required();
                    app.add_option("--vis", opt->vis, "visible image (same size)")->required();
                    app.add_option("--out", opt->out, "fused image to write")->required();
                    app.add_option("--method", opt->method, "vsmwls | vsmwls-paper | fast")
                        ->capture_default_str();
                    app.add_option("--colour", opt->colour,
                                   "rgb (fuse every visible channel, VIFB) | luminance (fuse Y, "
                                   "keep the visible chroma)")
                        ->capture_default_str();
                    app.add_option("--fast-scale", opt->fast_scale,
                                   "fast method: reduction of its working grid")
                        ->capture_default_str()
                        ->check(CLI::Range(1, 16));
                    app.add_flag("--enhance", opt->enhance,
                                 "infrared AGC and visible CLAHE before fusing");
                    app.add_flag("--json", opt->json, "print one JSON object");
                    return [opt] { return run_fuse(*opt); };
                  });

THERMOVIS_COMMAND(
    "fuse-eval",
    "Fuse every pair of a VIFB-like folder (IR/, VI/) and print VIFB's metrics "
    "beside VIFB's published values",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<EvalOptions>();
      app.add_option("--dir", opt->dir,
                     "folder with IR/ and VI/ (and optionally "
                     "vifb_metrics_average.csv)")
          ->required();
      app.add_option("--method", opt->methods,
                     "one or more of vsmwls, vsmwls-paper, fast (side by side)")
          ->delimiter(',')
          ->capture_default_str();
      app.add_option("--colour", opt->colour, "rgb | luminance")->capture_default_str();
      app.add_option("--fast-scale", opt->fast_scale, "fast method: reduction of its working grid")
          ->capture_default_str()
          ->check(CLI::Range(1, 16));
      app.add_flag("--no-jpeg", opt->no_jpeg,
                   "score the 8-bit output itself instead of its quality-75 JPEG");
      app.add_option("--save", opt->save, "folder to write the fused images to");
      app.add_flag("--json", opt->json,
                   "print {\"pairs\", \"mean\": {metric: value}, \"ms_per_pair\"} "
                   "per method, one JSON line each");
      return [opt] { return run_fuse_eval(*opt); };
    });

}  // namespace
