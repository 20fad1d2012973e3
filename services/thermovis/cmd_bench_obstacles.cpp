// thermovis bench obstacles: obstacles of any class from the stereo geometry (common/obstacle)
// on the simulated rig, through the pipeline's rectification: each capture of a scene (the
// street by default: people, an oncoming and a crossing car, two poles) rectified onto the
// pipeline grid, its obstacles found on the pairs the band names and matched to the simulated
// truth; then the same scene without targets or walls (an empty road) for the false obstacles.
// Prints recall up to --recall-m, the distance error per distance, false obstacles per 100
// frames of empty road, and the stage's CPU per capture.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "capture_floor.hpp"
#include "command.hpp"
#include "scene_arg.hpp"
#include "thermovis/metrics/percentile.hpp"
#include "thermovis/obstacle/obstacles.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/grid_options.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace {

namespace ob = thermovis::obstacle;
namespace pl = thermovis::pipeline;
namespace sim = thermovis::sim;
using thermovis::metrics::percentile;

struct Options {
  std::string rig;
  std::string scene = "street";
  int frames = 50;
  int frame_step = 10;  // frames apart (the targets move between measured captures)
  int empty_frames = 50;
  std::string band = "both";
  std::string method = "bm";
  double recall_m = 40.0;
  std::uint64_t seed = 1;
  bool json = false;
  std::string dump;  // folder: the first capture of each scene drawn
  bool share_ground = false;
  bool no_fixed_pattern = false;            // the infrared cameras without their per-pixel offsets
  bool track_ground = false;                // each pair's ground searched about the last capture's
  bool no_far_band = false;                 // ObstacleOptions::far_band off
  double texture_noise_factor = -1;         // >= 0: DenseOptions::texture_noise_factor
  double counts_texture_noise_factor = -1;  // >= 0: ObstacleOptions::counts_texture_noise_factor
  pl::GridOptions grid;
};

// Distance bins of the report, m (upper bounds).
constexpr double kBins[] = {10, 20, 30, 40, 60, 1e9};

struct Bin {
  int truths = 0, found = 0;
  std::vector<double> errors, abs_errors, rel_errors;  // m, m, share
};

// A target's truth: its silhouette's box on the grid and the horizontal distance of its nearest
// surface point from the reporting camera (what an obstacle's distance measures).
struct Truth {
  std::string id;
  cv::Rect box;
  double distance_m = 0;
  bool visible = false;  // in view of the left eye (not hidden behind a wall or another target)
};

std::vector<Truth> truths_of(const sim::SimulatedRig& simulated, const pl::PipelineGeometry& g,
                             std::int64_t frame, const Eigen::Vector3d& down_reporting,
                             int left_margin_px) {
  std::vector<Truth> out;
  const Eigen::Isometry3d& T_ref_vl = g.T_ref_reporting;
  const Eigen::Vector3d eye = T_ref_vl.translation();
  for (const sim::TargetTruth& t : simulated.truth(frame)) {
    Truth truth;
    truth.id = t.id;
    truth.box = pl::points_box_on_grid(g, pl::Band::visible, t.surface_points_m);
    truth.distance_m = 1e300;
    for (const Eigen::Vector3d& p : t.surface_points_m) {
      truth.distance_m =
          std::min(truth.distance_m, (p - down_reporting.dot(p) * down_reporting).norm());
    }
    // In view: a fifth of its surface points' rays (a sample) meet it first.
    int hits = 0, rays = 0;
    const std::size_t step = std::max<std::size_t>(1, t.surface_points_m.size() / 40);
    for (std::size_t i = 0; i < t.surface_points_m.size(); i += step, ++rays) {
      const Eigen::Vector3d to = T_ref_vl * t.surface_points_m[i] - eye;
      hits += simulated.trace(eye, to, frame).target_id == t.id;
    }
    truth.visible = !truth.box.empty() && rays > 0 && hits * 5 >= rays &&
                    truth.box.x >= left_margin_px && truth.box.br().x < g.grid.width;
    out.push_back(truth);
  }
  return out;
}

// One target over the captures where it was in view.
struct PerTarget {
  int seen = 0, found = 0;
  double truth_sum_m = 0;
  std::vector<double> errors;  // m, where found
};

std::size_t bin_of(double distance_m) {
  std::size_t i = 0;
  while (distance_m > kBins[i]) ++i;
  return i;
}

std::string bin_name(std::size_t i) {
  const double lo = i == 0 ? 0 : kBins[i - 1];
  return i + 1 == std::size(kBins) ? ">" + std::to_string(static_cast<int>(lo))
                                   : std::to_string(static_cast<int>(lo)) + "-" +
                                         std::to_string(static_cast<int>(kBins[i]));
}

// --dump: the visible left image of the grid with the obstacles (red: visible pair, blue:
// infrared, magenta: both) and the free space (green), and each pair's reduced disparity.
void dump_capture(const std::string& prefix, const ob::ObstacleDetector& detector,
                  const pl::GridCapture& c, const ob::ObstacleResult& r) {
  cv::Mat view;
  cv::cvtColor(c.grey_left, view, cv::COLOR_GRAY2BGR);
  for (std::size_t x = 0; x < r.free_space_m.size(); ++x) {
    const float d = r.free_space_m[x];
    if (!std::isfinite(d)) continue;
    const int y = static_cast<int>(view.rows - 1 - d * 4);
    if (y >= 0) view.at<cv::Vec3b>(y, static_cast<int>(x)) = cv::Vec3b(0, 255, 0);
  }
  for (const ob::Obstacle& o : r.obstacles) {
    const cv::Scalar colour =
        o.bands == (ob::kVisibleBit | ob::kInfraredBit)
            ? cv::Scalar(255, 0, 255)
            : (o.bands == ob::kVisibleBit ? cv::Scalar(0, 0, 255) : cv::Scalar(255, 0, 0));
    cv::rectangle(view, o.box, colour, 1);
    std::ostringstream label;
    label << std::fixed << std::setprecision(1) << o.distance_m;
    cv::putText(view, label.str(), o.box.tl() + cv::Point(0, -2), cv::FONT_HERSHEY_PLAIN, 0.8,
                colour);
  }
  cv::imwrite(prefix + "_obstacles.png", view);
  for (const ob::PairObstacles& p : r.pairs) {
    std::cerr << ob::band_name(p.band) << " ground " << ob::status_name(p.ground.status) << " "
              << p.ground.message << " height " << p.ground.plane.height_m << " normal "
              << p.ground.plane.normal.transpose() << " inliers " << p.ground.inlier_pixels << "/"
              << p.ground.valid_pixels << " rows " << p.ground.rows_with_ground << "/"
              << p.ground.rows_searched << "\n";
    for (const ob::Obstacle& o : p.obstacles) {
      std::cerr << "  obstacle " << o.box << " d " << o.distance_m << " +- " << o.sigma_m << " ext "
                << o.extent_m.transpose() << " n " << o.stixels << "\n";
      const int k = detector.options().reduction;
      for (const ob::Stixel& s : p.stixels) {
        if (s.column * k < o.box.x || s.column * k >= o.box.br().x) continue;
        std::cerr << "    stixel column " << s.column << " rows " << s.top_row << "-" << s.base_row
                  << " d " << s.disparity_px << " px " << s.distance_m << " m height " << s.height_m
                  << " m\n";
      }
    }
    cv::Mat l8, r8;
    const bool visible = p.band == ob::PairBand::visible;
    detector.reduce_pair(p.band, visible ? c.grey_left : c.infrared_left,
                         visible ? c.grey_right : c.infrared_right, l8, r8);
    std::cerr << "  reduced left image: noise " << ob::image_noise_sigma(l8)
              << " grey levels (upper bound), block texture threshold "
              << ob::block_texture_threshold(
                     l8, detector.dense_options_for(visible ? c.grey_left : c.infrared_left))
              << "\n";
    const cv::Mat d =
        ob::dense_disparity(l8, r8, detector.max_disparity_px(),
                            detector.dense_options_for(visible ? c.grey_left : c.infrared_left));
    cv::Mat shown;
    d.convertTo(shown, CV_8U, 255.0 / detector.max_disparity_px());
    cv::applyColorMap(shown, shown, cv::COLORMAP_JET);
    shown.setTo(cv::Scalar::all(0), d != d);
    cv::imwrite(prefix + "_" + ob::band_name(p.band) + "_disparity.png", shown);
    cv::imwrite(prefix + "_" + ob::band_name(p.band) + "_left.png", l8);
  }
}

int run_bench_obstacles(const Options& opt) {
  if (opt.frames < 1) throw std::invalid_argument("--frames must be >= 1");
  if (opt.frame_step < 1) throw std::invalid_argument("--frame-step must be >= 1");
  if (opt.empty_frames < 0) throw std::invalid_argument("--empty-frames must be >= 0");
  if (!(opt.recall_m > 0)) throw std::invalid_argument("--recall-m must be > 0");
  if (opt.band != "both" && opt.band != "visible" && opt.band != "infrared") {
    throw std::invalid_argument("--band: '" + opt.band + "' is not both, visible or infrared");
  }
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  const sim::Scene scene = thermovis::runtime::load_scene(thermovis::cli::resolve_scene(opt.scene));
  pl::CapturePipelineOptions options;
  options.grid = opt.grid;
  pl::CapturePipeline pipeline(rig, options);
  const pl::PipelineGeometry& g = pipeline.geometry();

  ob::ObstacleOptions obstacle_options;
  obstacle_options.dense.method = ob::parse_dense_method(opt.method);
  if (opt.texture_noise_factor >= 0) {
    obstacle_options.dense.texture_noise_factor = opt.texture_noise_factor;
  }
  if (opt.counts_texture_noise_factor >= 0) {
    obstacle_options.counts_texture_noise_factor = opt.counts_texture_noise_factor;
  }
  obstacle_options.share_ground = opt.share_ground;
  obstacle_options.far_band = !opt.no_far_band;
  ob::GroundPrior prior;
  prior.camera_height_m = scene.camera_height_m;  // the simulated rig is level
  std::vector<ob::PairSetup> pairs;
  if (opt.band != "infrared")
    pairs.push_back({ob::PairBand::visible, g.ranging(pl::Band::visible)});
  if (opt.band != "visible") {
    pairs.push_back({ob::PairBand::infrared, g.ranging(pl::Band::infrared), g.infrared_reduction});
  }
  const ob::ObstacleDetector detector(g.grid, pairs, g.T_ref_reporting, prior, obstacle_options);
  const Eigen::Vector3d down = ob::plane_in_frame(ob::prior_plane(prior), g.T_ref_reporting).normal;
  // Targets the dense matcher cannot see (its search range at the left border) are not counted.
  const int left_margin =
      static_cast<int>(std::ceil(detector.max_disparity_px())) * obstacle_options.reduction;

  std::vector<double> cpu_ms;
  std::vector<Bin> bins(std::size(kBins));
  std::map<std::string, PerTarget> per_target;
  int obstacles_total = 0, obstacles_on_target = 0, no_ground = 0, ground_tracked = 0, captures = 0;
  ob::GroundTracks tracks;
  auto run = [&](const sim::SimulatedRig& simulated, std::int64_t frame) {
    sim::FrameSet frames = simulated.allocate();
    simulated.render(frame, frames);
    const pl::GridCapture c =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    const thermovis::cli::OneOpenCvThread one_thread;
    const double t0 = thermovis::cli::thread_cpu_ms();
    if (captures == opt.frames) tracks.reset();  // the empty road: another stream
    ob::ObstacleResult r =
        opt.track_ground
            ? detector.detect(c.grey_left, c.grey_right, c.infrared_left, c.infrared_right, tracks)
            : detector.detect(c.grey_left, c.grey_right, c.infrared_left, c.infrared_right);
    cpu_ms.push_back(thermovis::cli::thread_cpu_ms() - t0);
    // The first capture of each scene, and every empty-road frame with a (false) obstacle.
    const bool empty_road = captures >= opt.frames;
    if (!opt.dump.empty() &&
        (captures == 0 || captures == opt.frames || (empty_road && !r.obstacles.empty()))) {
      std::string prefix = opt.dump + "/" + simulated.scene().name;
      if (empty_road && captures > opt.frames) prefix += "_" + std::to_string(frame);
      std::cerr << prefix << ":\n";
      dump_capture(prefix, detector, c, r);
    }
    ++captures;
    for (const auto& p : r.pairs) {
      no_ground += !p.ok();
      ground_tracked += p.ground_tracked;
    }
    return r;
  };

  const sim::RenderOptions render{true, !opt.no_fixed_pattern};
  const sim::SimulatedRig simulated(rig, scene, opt.seed, render);
  for (int i = 0; i < opt.frames; ++i) {
    const std::int64_t frame = static_cast<std::int64_t>(i) * opt.frame_step;
    const ob::ObstacleResult r = run(simulated, frame);
    const std::vector<Truth> truths = truths_of(simulated, g, frame, down, left_margin);
    obstacles_total += static_cast<int>(r.obstacles.size());
    for (const ob::Obstacle& o : r.obstacles) {
      obstacles_on_target += std::any_of(truths.begin(), truths.end(), [&](const Truth& t) {
        return (t.box & o.box).area() > 0.2 * std::min(t.box.area(), o.box.area());
      });
    }
    for (const Truth& t : truths) {
      if (!t.visible) continue;
      // The obstacle over the target's box nearest to its distance.
      const ob::Obstacle* best = nullptr;
      for (const ob::Obstacle& o : r.obstacles) {
        if ((t.box & o.box).area() <= 0.2 * std::min(t.box.area(), o.box.area())) continue;
        if (best == nullptr ||
            std::abs(o.distance_m - t.distance_m) < std::abs(best->distance_m - t.distance_m)) {
          best = &o;
        }
      }
      Bin& bin = bins[bin_of(t.distance_m)];
      PerTarget& target = per_target[t.id];
      ++bin.truths;
      ++target.seen;
      target.truth_sum_m += t.distance_m;
      if (best == nullptr) continue;
      const double error = best->distance_m - t.distance_m;
      // Found: at its distance within 15 % (+ 0.5 m); farther off it is another object's.
      if (std::abs(error) > 0.5 + 0.15 * t.distance_m) continue;
      ++bin.found;
      ++target.found;
      target.errors.push_back(error);
      bin.errors.push_back(error);
      bin.abs_errors.push_back(std::abs(error));
      bin.rel_errors.push_back(std::abs(error) / t.distance_m);
    }
  }

  // The empty road: the scene without its targets and walls.
  sim::Scene empty = scene;
  empty.name = scene.name + "_empty_road";
  empty.targets.clear();
  empty.walls.clear();
  int false_obstacles = 0;
  if (opt.empty_frames > 0) {
    const sim::SimulatedRig road(rig, empty, opt.seed + 1, render);
    for (int i = 0; i < opt.empty_frames; ++i) {
      false_obstacles += static_cast<int>(run(road, i).obstacles.size());
    }
  }

  int truths_in_reach = 0, found_in_reach = 0;
  for (std::size_t i = 0; i < bins.size(); ++i) {
    if (kBins[i] <= opt.recall_m || (i > 0 && kBins[i - 1] < opt.recall_m)) {
      truths_in_reach += bins[i].truths;
      found_in_reach += bins[i].found;
    }
  }
  const double recall = truths_in_reach > 0 ? 100.0 * found_in_reach / truths_in_reach : 0.0;
  const double false_per_100 =
      opt.empty_frames > 0 ? 100.0 * false_obstacles / opt.empty_frames : 0.0;
  if (opt.json) {
    nlohmann::json targets = nlohmann::json::array();
    for (const auto& [id, t] : per_target) {
      targets.push_back({{"id", id},
                         {"truth_distance_m", t.truth_sum_m / t.seen},
                         {"in_view", t.seen},
                         {"found", t.found},
                         {"median_error_m", t.found ? percentile(t.errors, 50) : 0.0}});
    }
    nlohmann::json per = nlohmann::json::array();
    for (std::size_t i = 0; i < bins.size(); ++i) {
      const Bin& b = bins[i];
      per.push_back({{"distance_m", bin_name(i)},
                     {"truths", b.truths},
                     {"found", b.found},
                     {"median_error_m", b.found ? percentile(b.errors, 50) : 0.0},
                     {"median_abs_error_m", b.found ? percentile(b.abs_errors, 50) : 0.0},
                     {"median_rel_error_pct", b.found ? 100 * percentile(b.rel_errors, 50) : 0.0}});
    }
    std::cout << nlohmann::json{{"scene", opt.scene},
                                {"band", opt.band},
                                {"method", opt.method},
                                {"frames", opt.frames},
                                {"recall_up_to_m", opt.recall_m},
                                {"recall_pct", recall},
                                {"per_distance", per},
                                {"targets", targets},
                                {"obstacles", obstacles_total},
                                {"obstacles_on_a_target", obstacles_on_target},
                                {"pairs_without_ground", no_ground},
                                {"pairs_ground_tracked", ground_tracked},
                                {"empty_road_frames", opt.empty_frames},
                                {"false_obstacles_per_100_frames", false_per_100},
                                {"cpu_ms_median", percentile(cpu_ms, 50)},
                                {"cpu_ms_p95", percentile(cpu_ms, 95)}}
                     .dump()
              << "\n";
    return 0;
  }
  std::cout << "Obstacles (" << ob::method_name(obstacle_options.dense.method) << ", band "
            << opt.band << ") on scene " << opt.scene << ", grid " << g.grid.width << "x"
            << g.grid.height << ", " << opt.frames << " captures " << opt.frame_step
            << " frames apart\n"
            << std::fixed << std::setprecision(1);
  std::cout << std::setw(10) << "distance" << std::setw(8) << "truths" << std::setw(8) << "found"
            << std::setw(16) << "median |error|" << std::setw(10) << "of dist." << std::setw(16)
            << "median error\n";
  for (std::size_t i = 0; i < bins.size(); ++i) {
    const Bin& b = bins[i];
    if (b.truths == 0) continue;
    std::cout << std::setw(10) << bin_name(i) << std::setw(8) << b.truths << std::setw(8) << b.found
              << std::setw(14) << std::setprecision(2)
              << (b.found ? percentile(b.abs_errors, 50) : 0.0) << " m" << std::setw(8)
              << std::setprecision(1) << (b.found ? 100 * percentile(b.rel_errors, 50) : 0.0)
              << " %" << std::setw(12) << std::showpos << std::setprecision(2)
              << (b.found ? percentile(b.errors, 50) : 0.0) << std::noshowpos << " m\n";
  }
  std::cout << "per target (in view, found, median error):";
  for (const auto& [id, t] : per_target) {
    std::cout << "\n  " << std::left << std::setw(14) << id << std::right << std::setw(7)
              << std::setprecision(1) << t.truth_sum_m / t.seen << " m" << std::setw(5) << t.seen
              << std::setw(5) << t.found;
    if (t.found > 0) {
      std::cout << std::setw(10) << std::showpos << std::setprecision(2) << percentile(t.errors, 50)
                << std::noshowpos << " m";
    }
  }
  std::cout << "\n"
            << std::setprecision(1) << "recall up to " << opt.recall_m << " m: " << found_in_reach
            << " of " << truths_in_reach << " (" << recall << " %)\n"
            << "obstacles " << obstacles_total << ", of which on a target " << obstacles_on_target
            << " (the others: walls, hedge, buildings); pairs without ground " << no_ground << "\n"
            << "false obstacles on the empty road: " << false_obstacles << " in "
            << opt.empty_frames << " frames (" << false_per_100 << " per 100)\n"
            << std::setprecision(2) << "CPU per capture (one thread): median "
            << percentile(cpu_ms, 50) << " ms, p95 " << percentile(cpu_ms, 95) << " ms\n";
  return 0;
}

THERMOVIS_COMMAND(
    "bench obstacles",
    "Obstacles from the stereo geometry on the simulated rig: recall, distance error per "
    "distance, false obstacles on an empty road, CPU per capture",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--scene", opt->scene, "shipped scene name or scene YAML")
          ->capture_default_str();
      app.add_option("--frames", opt->frames, "captures measured")->capture_default_str();
      app.add_option("--frame-step", opt->frame_step, "frames between two captures measured")
          ->capture_default_str();
      app.add_option("--empty-frames", opt->empty_frames,
                     "captures of the empty road (the scene without targets and walls)")
          ->capture_default_str();
      app.add_option("--band", opt->band, "both | visible | infrared")->capture_default_str();
      app.add_option("--method", opt->method, "dense disparity: bm | sgbm")->capture_default_str();
      app.add_option("--recall-m", opt->recall_m, "recall of the targets up to this distance")
          ->capture_default_str();
      app.add_option("--seed", opt->seed, "noise seed")->capture_default_str();
      app.add_flag("--no-fixed-pattern", opt->no_fixed_pattern,
                   "render the infrared cameras without fixed-pattern noise (a corrected camera)");
      app.add_flag("--share-ground", opt->share_ground,
                   "a pair without a ground of its own takes the other's");
      app.add_option("--texture-noise-factor", opt->texture_noise_factor,
                     "block matching: a block's texture at least this many times its noise's "
                     "(0: the fixed threshold alone; default: the detector's)");
      app.add_option("--counts-texture-noise-factor", opt->counts_texture_noise_factor,
                     "the same for the infrared pair's counts (default: the detector's)");
      app.add_flag("--track-ground", opt->track_ground,
                   "each pair's ground searched about the last capture's (GroundTracks)");
      app.add_flag("--no-far-band", opt->no_far_band,
                   "the reduced grid alone: the visible pair not matched again on the grid's "
                   "own pixels about the horizon");
      app.add_flag("--json", opt->json, "one JSON object");
      app.add_option("--dump", opt->dump,
                     "folder: the first capture of each scene and every empty-road frame with an "
                     "obstacle drawn (obstacles, disparity)");
      thermovis::runtime::add_grid_options(app, opt->grid);
      return [opt] { return run_bench_obstacles(*opt); };
    });

}  // namespace
