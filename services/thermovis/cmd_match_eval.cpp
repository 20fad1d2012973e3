// thermovis match-eval: accuracy and speed of every matching method on Middlebury scenes with
// ground-truth disparity (fraction of matches within 1 px and 0.5 px, number of matches, ms per
// pair), the whole left image being the target box; and the obstacle stage's dense methods
// (common/obstacle: bad-1 and bad-2 %, the share of pixels with a disparity, ms per pair).
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/match/middlebury.hpp"
#include "thermovis/obstacle/dense_disparity.hpp"

namespace {

namespace fs = std::filesystem;
namespace mt = thermovis::match;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string data = "../shared/data/stereo/middlebury2014_quarter";
  std::string methods = "orb,akaze,sift,ncc,sgbm";
  std::string dense = "bm,sgbm";
  int repeat = 1;
  bool no_subpixel = false;
  int max_points = 0;
  bool json = false;
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

int run_match_eval(const Options& opt) {
  if (!fs::is_directory(opt.data)) {
    throw std::runtime_error("--data: no folder " + opt.data);
  }
  if (opt.repeat < 1) throw std::invalid_argument("--repeat must be >= 1");
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(opt.data)) {
    if (entry.is_directory() && fs::exists(entry.path() / "disp0GT.pfm"))
      folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  if (folders.empty())
    throw std::runtime_error("--data: no scene with disp0GT.pfm under " + opt.data);
  std::vector<mt::MiddleburyScene> scenes;
  for (const auto& f : folders) scenes.push_back(mt::load_middlebury_scene(f));

  nlohmann::json rows = nlohmann::json::array();
  for (const std::string& name : split(opt.methods)) {
    mt::MatchOptions o;
    o.method = mt::parse_method(name);
    o.subpixel = !opt.no_subpixel;
    o.max_points = opt.max_points;
    mt::MatchAccuracy total;
    double ms_total = 0, abs_sum = 0;
    nlohmann::json per_scene = nlohmann::json::array();
    for (const auto& scene : scenes) {
      o.min_disparity_px = 0;
      o.max_disparity_px = scene.ndisp;
      double best_ms = 1e30;
      mt::MatchResult result;
      for (int k = 0; k < opt.repeat; ++k) {
        const auto t0 = Clock::now();
        result = mt::match_box(scene.left, scene.right,
                               cv::Rect(0, 0, scene.left.cols, scene.left.rows), o);
        best_ms =
            std::min(best_ms, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
      const mt::MatchAccuracy a = mt::evaluate_matches(result.matches, scene.ground_truth);
      per_scene.push_back({{"scene", scene.name},
                           {"matches", a.matches},
                           {"within_1px", a.fraction_1px()},
                           {"within_half_px", a.fraction_half_px()},
                           {"ms", best_ms}});
      total.matches += a.matches;
      total.with_truth += a.with_truth;
      total.within_1px += a.within_1px;
      total.within_half_px += a.within_half_px;
      abs_sum += a.mean_abs_error_px * a.within_1px;
      ms_total += best_ms;
    }
    const double n = static_cast<double>(scenes.size());
    rows.push_back(
        {{"method", name},
         {"subpixel", o.subpixel},
         {"scenes", scenes.size()},
         {"matches_per_pair", total.matches / n},
         {"within_1px", total.fraction_1px()},
         {"within_half_px", total.fraction_half_px()},
         {"mean_abs_error_px_inliers", total.within_1px ? abs_sum / total.within_1px : 0.0},
         {"ms_per_pair", ms_total / n},
         {"per_scene", per_scene}});
  }
  // The obstacle stage's dense methods, with its options, over each scene's ndisp.
  nlohmann::json dense_rows = nlohmann::json::array();
  for (const std::string& name : split(opt.dense)) {
    thermovis::obstacle::DenseOptions o;
    o.method = thermovis::obstacle::parse_dense_method(name);
    double truth = 0, valid = 0, bad1 = 0, bad2 = 0, bad1_valid = 0, ms_total = 0;
    nlohmann::json per_scene = nlohmann::json::array();
    for (const auto& scene : scenes) {
      cv::Mat left8, right8, d;
      thermovis::obstacle::grey_pair(scene.left, scene.right, left8, right8);
      double best_ms = 1e30;
      for (int k = 0; k < opt.repeat; ++k) {
        const auto t0 = Clock::now();
        d = thermovis::obstacle::dense_disparity(left8, right8, scene.ndisp, o);
        best_ms =
            std::min(best_ms, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
      const auto a = thermovis::obstacle::evaluate_dense(d, scene.ground_truth);
      per_scene.push_back({{"scene", scene.name},
                           {"bad1", a.bad1},
                           {"bad2", a.bad2},
                           {"valid", a.valid},
                           {"bad1_valid", a.bad1_valid},
                           {"ms", best_ms}});
      // Pooled over the scenes' pixels with a truth.
      truth += a.truth_pixels;
      valid += a.valid * a.truth_pixels;
      bad1 += a.bad1 * a.truth_pixels;
      bad2 += a.bad2 * a.truth_pixels;
      bad1_valid += a.bad1_valid * a.valid * a.truth_pixels;
      ms_total += best_ms;
    }
    dense_rows.push_back({{"dense_method", name},
                          {"scenes", scenes.size()},
                          {"bad1", truth > 0 ? bad1 / truth : 0.0},
                          {"bad2", truth > 0 ? bad2 / truth : 0.0},
                          {"valid", truth > 0 ? valid / truth : 0.0},
                          {"bad1_valid", valid > 0 ? bad1_valid / valid : 0.0},
                          {"ms_per_pair", ms_total / static_cast<double>(scenes.size())},
                          {"per_scene", per_scene}});
  }
  if (opt.json) {
    for (const auto& row : rows) std::cout << row.dump() << "\n";
    for (const auto& row : dense_rows) std::cout << row.dump() << "\n";
    return 0;
  }
  std::cout << "Middlebury " << opt.data << " (" << scenes.size()
            << " pairs, whole image as the box, best of " << opt.repeat << " runs)\n";
  std::cout << std::left << std::setw(8) << "method" << std::right << std::setw(10) << "matches"
            << std::setw(10) << "<=1 px" << std::setw(10) << "<=0.5 px" << std::setw(14)
            << "|err| <=1px" << std::setw(10) << "ms/pair"
            << "\n"
            << std::fixed;
  for (const auto& r : rows) {
    std::cout << std::left << std::setw(8) << r["method"].get<std::string>() << std::right
              << std::setprecision(0) << std::setw(10) << r["matches_per_pair"].get<double>()
              << std::setprecision(1) << std::setw(9) << 100 * r["within_1px"].get<double>() << "%"
              << std::setw(9) << 100 * r["within_half_px"].get<double>() << "%"
              << std::setprecision(3) << std::setw(14)
              << r["mean_abs_error_px_inliers"].get<double>() << std::setprecision(1)
              << std::setw(10) << r["ms_per_pair"].get<double>() << "\n";
  }
  if (dense_rows.empty()) return 0;
  std::cout << "\nDense disparity (the obstacle stage's; a pixel without a disparity counts bad)\n"
            << std::left << std::setw(8) << "method" << std::right << std::setw(10) << "bad-1"
            << std::setw(10) << "bad-2" << std::setw(10) << "valid" << std::setw(16)
            << "bad-1 of valid" << std::setw(10) << "ms/pair"
            << "\n";
  for (const auto& r : dense_rows) {
    std::cout << std::left << std::setw(8) << r["dense_method"].get<std::string>() << std::right
              << std::setprecision(1) << std::setw(9) << 100 * r["bad1"].get<double>() << "%"
              << std::setw(9) << 100 * r["bad2"].get<double>() << "%" << std::setw(9)
              << 100 * r["valid"].get<double>() << "%" << std::setw(15)
              << 100 * r["bad1_valid"].get<double>() << "%" << std::setw(10)
              << r["ms_per_pair"].get<double>() << "\n";
  }
  return 0;
}

THERMOVIS_COMMAND(
    "match-eval",
    "Matching accuracy (within 1 px / 0.5 px of the ground truth), matches and ms "
    "per pair of every method on Middlebury scenes",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--data", opt->data,
                     "folder of MiddEval3 scenes (im0/im1.png, disp0GT.pfm, calib.txt)");
      app.add_option("--methods", opt->methods, "comma-separated: orb,akaze,sift,ncc,sgbm");
      app.add_option("--repeat", opt->repeat, "runs per pair; the fastest is reported");
      app.add_option("--dense", opt->dense,
                     "comma-separated dense methods of the obstacle stage: bm,sgbm (empty: none)");
      app.add_flag("--no-subpixel", opt->no_subpixel, "skip the sub-pixel refinement");
      app.add_option("--max-points", opt->max_points,
                     "ncc: corners searched per pair (0 = all: the whole image is one box; "
                     "ranging searches 200 per target box)")
          ->capture_default_str();
      app.add_flag("--json", opt->json, "one JSON object per method");
      return [opt] { return run_match_eval(*opt); };
    });

}  // namespace
