// thermovis bench ranging: the paper's Table 6 on the simulated rig. For each trial, one scene
// holds a person at every requested distance (random bearing where no wall and no other person
// hides it, random clothing, illuminance and air temperature, fresh noise seed); each person's
// truth box (raw left image) is ranged in every mode and compared with the true distance of its
// centre. Prints per distance and mode the mean and max absolute error beside the paper's.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>

#include "command.hpp"
#include "thermovis/match/shift_bound.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/grid_options.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/util/enum_names.hpp"

namespace {

namespace rg = thermovis::range;
namespace pl = thermovis::pipeline;
namespace sim = thermovis::sim;

struct Options {
  std::string rig;
  std::string distances = "5,10,15,20,25,30,40,60";
  int trials = 5;
  std::string mode = "all";
  std::string method = "ncc";
  std::uint64_t seed = 1;
  bool json = false;
  bool points = false;
  bool bound = false;
  std::string estimate = "both";
  pl::GridOptions grid;
};

// The ranging modes of Table 6 and the pipeline's band choice for each (fused: both pairs
// matched and their ranges combined, the pipeline's default).
enum class Mode { visible, infrared, fused };
constexpr thermovis::util::EnumName<Mode> kModeNames[] = {
    {Mode::visible, "visible"}, {Mode::infrared, "infrared"}, {Mode::fused, "fused"}};
std::string mode_name(Mode mode) { return thermovis::util::name_of(kModeNames, mode, "fused"); }
Mode parse_mode(const std::string& name) {
  if (const auto mode = thermovis::util::parse(kModeNames, name)) return *mode;
  throw std::invalid_argument("unknown ranging mode '" + name + "' (expected " +
                              thermovis::util::join_names(kModeNames, ", ", " or ") + ")");
}
pl::BandChoice band_choice(Mode mode) {
  return mode == Mode::visible    ? pl::BandChoice::visible
         : mode == Mode::infrared ? pl::BandChoice::infrared
                                  : pl::BandChoice::both;
}

// Table 6 of the paper: absolute difference (m) per distance for visible, infrared, fused.
struct PaperRow {
  double visible, infrared, fused;
};
const std::map<int, PaperRow> kTable6 = {{5, {0.18, 0.05, 0.01}},  {10, {0.15, 0.02, 0.0}},
                                         {15, {0.36, 0.04, 0.02}}, {20, {0.99, 0.16, 0.02}},
                                         {25, {0.86, 0.47, 0.14}}, {30, {1.62, 0.47, 0.37}},
                                         {40, {2.01, 0.54, 0.22}}, {60, {3.24, 2.55, 0.35}}};

std::optional<double> paper_error(double distance, Mode mode) {
  const auto it = kTable6.find(static_cast<int>(std::lround(distance)));
  if (it == kTable6.end() || std::abs(distance - it->first) > 1e-9) return std::nullopt;
  switch (mode) {
    case Mode::visible:
      return it->second.visible;
    case Mode::infrared:
      return it->second.infrared;
    case Mode::fused:
      return it->second.fused;
  }
  return std::nullopt;
}

std::vector<double> parse_distances(const std::string& text) {
  std::vector<double> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    try {
      const double d = std::stod(item);
      if (!(d > 0.5) || !std::isfinite(d)) throw std::invalid_argument("");
      out.push_back(d);
    } catch (const std::exception&) {
      throw std::invalid_argument("--distances: '" + item +
                                  "' is not a distance in metres (> 0.5)");
    }
  }
  if (out.empty()) throw std::invalid_argument("--distances: none given");
  return out;
}

struct Cell {
  std::vector<double> errors;
  int within_sigma = 0, failures = 0;
  int hidden = 0;  // the left eye's ray to the person's centre meets something else first
  std::vector<std::string> why;  // each failure: the box's size, the true disparity and why
  double sigma_sum = 0;
  // --points: the kept points against the simulator's geometry (evaluation only).
  int points = 0, on_target = 0;
  double disparity_error_sum = 0, disparity_error_sum2 = 0;  // on-target points, px
  double off_target_error_sum = 0;            // off-target points vs the target centre's, px
  double centre_offset_sum = 0;               // true centre distance - true point distance, m
  std::vector<double> true_disparity_errors;  // the estimator on true disparities, m
  // --bound: the least mean |error| the target's pixels allow (shift_bound.hpp), summed.
  double bound_abs_sum = 0;
  int bounds = 0;
};

// Whether the 2-D segments p-q and a-b cross.
bool segments_cross(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                    const Eigen::Vector2d& b) {
  const auto side = [](const Eigen::Vector2d& o, const Eigen::Vector2d& u,
                       const Eigen::Vector2d& v) {
    const double c = (u - o).x() * (v - o).y() - (u - o).y() * (v - o).x();
    return (c > 0) - (c < 0);
  };
  return side(p, q, a) * side(p, q, b) <= 0 && side(a, b, p) * side(a, b, q) <= 0;
}

// A person at `distance_m`, `bearing_deg` (the scene's convention: foot point at
// (L sin b, L cos b) on the ground, from the reference camera) is in clear view when the sight
// lines from both ends of a 0.5 m wide rig to both sides of the person (0.4 m either side of
// the foot point, across the line of sight) cross no wall.
bool in_clear_view(const sim::Scene& scene, double distance_m, double bearing_deg) {
  const double b = bearing_deg * M_PI / 180.0;
  const Eigen::Vector2d foot(distance_m * std::sin(b), distance_m * std::cos(b));
  const Eigen::Vector2d across(std::cos(b), -std::sin(b));
  for (const sim::Wall& wall : scene.walls) {
    for (double eye : {-0.05, 0.45}) {
      for (double side : {-0.4, 0.4}) {
        if (segments_cross({eye, 0.0}, foot + side * across, wall.from, wall.to)) return false;
      }
    }
  }
  return true;
}

// --points: each kept point of a ranged target traced in the simulated scene: whether its left
// pixel's ray meets the target, the true disparity there, and the range the same points would
// give with their true disparities.
void evaluate_points(const sim::SimulatedRig& simulated, const sim::TargetTruth& truth,
                     const rg::RangingGeometry& g, const cv::Rect& box, const pl::CaptureTarget& r,
                     const rg::RangeOptions& options, Cell& cell) {
  if (r.matches.size() != 1) return;  // fused: two pairs' points, each traced in its own mode
  const Eigen::Isometry3d& T = g.T_ref_left_rect;
  const Eigen::Isometry3d& T_ref_vl =
      simulated.rig().camera(simulated.rig().visible.left).T_ref_cam;
  Eigen::Vector2d centre_px;
  double centre_disparity = 0;
  const Eigen::Vector3d centre_rect = T.inverse() * (T_ref_vl * truth.position_m);
  if (!rg::project_point(g, centre_rect, centre_px, centre_disparity)) return;
  // The same matches with the true disparity wherever the pixel's ray meets the target.
  std::vector<thermovis::match::Correspondence> corrected = r.matches.front().result.matches;
  for (int k : r.ranged.range.used) {
    auto& c = corrected[static_cast<size_t>(k)];
    Eigen::Vector3d ray;
    if (!g.grid.unproject(c.left, ray)) continue;
    ray.normalize();
    ++cell.points;
    const sim::RayTruth hit = simulated.trace(T * Eigen::Vector3d::Zero(), T.linear() * ray, 0);
    if (hit.target_id != truth.id) {
      cell.off_target_error_sum += c.disparity_px - centre_disparity;
      continue;
    }
    ++cell.on_target;
    Eigen::Vector2d px;
    double d_true = 0;
    if (!rg::project_point(g, hit.distance_m * ray, px, d_true)) continue;
    const double e = c.disparity_px - d_true;
    cell.disparity_error_sum += e;
    cell.disparity_error_sum2 += e * e;
    cell.centre_offset_sum += centre_rect.norm() - hit.distance_m;
    c.disparity_px = d_true;
  }
  rg::TargetRange t = rg::range_target(g, box, corrected, options);
  if (t.status == rg::RangeStatus::ok) {
    cell.true_disparity_errors.push_back((T_ref_vl.inverse() * t.position_m).norm() -
                                         truth.distance_m);
  }
}

// --bound: one sigma (m) of the least range uncertainty a target's pixels allow in one band:
// the Cramer-Rao bound of its silhouette's shift between the eyes (match::shift_bound_px) on the
// noise-free images, with the noise the rendered ones have in the box (their difference's
// variance, each eye), times the metres per pixel of disparity at its true place. Its mask is
// every pixel of the box whose ray meets the target (the simulator's ray tracer), and the
// one-pixel ring about it (the outline). Infinity where the silhouette has no gradient.
double range_bound_m(const pl::CapturePipeline& pipeline, const sim::SimulatedRig& simulated,
                     const sim::TargetTruth& truth, const Eigen::Vector3d& centre_ref,
                     pl::Band band, const pl::GridCapture& clean, const pl::GridCapture& noisy) {
  const pl::PipelineGeometry& geometry = pipeline.geometry();
  const rg::RangingGeometry g = geometry.ranging(band);
  const int k = geometry.reduction(band);
  const bool visible = band == pl::Band::visible;
  const cv::Mat& clean_left = visible ? clean.grey_left : clean.infrared_left;
  const cv::Mat& clean_right = visible ? clean.grey_right : clean.infrared_right;
  const cv::Mat& noisy_left = visible ? noisy.grey_left : noisy.infrared_left;
  const cv::Mat& noisy_right = visible ? noisy.grey_right : noisy.infrared_right;
  const cv::Rect box =
      pl::reduce_box(pl::points_box_on_grid(geometry, band, truth.surface_points_m), k) &
      cv::Rect(cv::Point(), clean_left.size());
  if (box.empty()) return std::numeric_limits<double>::infinity();
  cv::Mat mask(clean_left.size(), CV_8UC1, cv::Scalar(0));
  const Eigen::Vector3d origin = g.T_ref_left_rect.translation();
  for (int y = box.y; y < box.y + box.height; ++y) {
    for (int x = box.x; x < box.x + box.width; ++x) {
      Eigen::Vector3d ray;
      const Eigen::Vector2d grid_px(pl::grid_coordinate(x, k), pl::grid_coordinate(y, k));
      if (!g.grid.unproject(grid_px, ray)) continue;
      if (simulated.trace(origin, g.T_ref_left_rect.linear() * ray, 0).target_id == truth.id) {
        mask.at<std::uint8_t>(y, x) = 1;
      }
    }
  }
  cv::dilate(mask, mask, cv::Mat::ones(3, 3, CV_8UC1));
  double variance_sum = 0;
  for (const auto& [c, n] : {std::pair{&clean_left, &noisy_left}, {&clean_right, &noisy_right}}) {
    cv::Mat a, b;
    (*c)(box).convertTo(a, CV_64F);
    (*n)(box).convertTo(b, CV_64F);
    cv::Scalar mean, deviation;
    cv::meanStdDev(b - a, mean, deviation);
    variance_sum += deviation[0] * deviation[0];
  }
  const double shift_px =
      thermovis::match::shift_bound_px(clean_left, mask, variance_sum) * k;  // grid px
  Eigen::Vector2d px;
  double disparity = 0;
  if (!rg::project_point(g, g.T_ref_left_rect.inverse() * centre_ref, px, disparity)) {
    return std::numeric_limits<double>::infinity();
  }
  const rg::PointTriangulation t = rg::triangulate(g, px, disparity);
  return t.valid ? shift_px * t.distance_per_px : std::numeric_limits<double>::infinity();
}

int run_bench_ranging(const Options& opt) {
  if (opt.trials < 1) throw std::invalid_argument("--trials must be >= 1");
  const std::vector<double> distances = parse_distances(opt.distances);
  std::vector<Mode> modes;
  if (opt.mode == "all") {
    modes = {Mode::visible, Mode::infrared, Mode::fused};
  } else {
    modes = {parse_mode(opt.mode)};
  }
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  const sim::Scene base =
      thermovis::runtime::load_scene(thermovis::runtime::shipped_scene_path("paper"));
  pl::CapturePipelineOptions options;
  options.grid = opt.grid;
  options.match.match.method = thermovis::match::parse_method(opt.method);
  options.range.estimate = pl::parse_range_estimate(opt.estimate);
  pl::CapturePipeline pipeline(rig, options);
  // The range stage's options for a person (what --points re-ranges with).
  rg::RangeOptions person;
  person.shape = rg::TargetShape::for_class("person");
  person.contour_reach_px = options.match.match.patch_radius;

  std::mt19937_64 rng(opt.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const std::vector<std::string> clothing = {"clothing", "clothing_red", "clothing_blue"};
  std::map<std::pair<double, Mode>, Cell> cells;
  const auto t_start = std::chrono::steady_clock::now();
  for (int trial = 0; trial < opt.trials; ++trial) {
    sim::Scene scene = base;
    scene.name = "bench_ranging";
    scene.targets.clear();
    // Bearings within +-50 deg, drawn so that every person is in clear view of both eyes: the
    // sight lines from the rig to the person's sides cross no wall of the scene, and no person
    // stands within 2 deg of another's silhouette (a nearer one would hide it).
    std::vector<size_t> order(distances.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), rng);
    std::vector<std::pair<double, double>> placed;  // bearing, half-width (deg)
    for (size_t i : order) {
      sim::Target t;
      std::ostringstream id;
      id << "person_" << distances[i] << "m";
      t.id = id.str();
      t.cls = sim::TargetClass::person;
      t.distance_m = distances[i];
      const double half_width = std::atan2(0.5, distances[i]) * 180 / M_PI;
      bool found = false;
      for (int attempt = 0; attempt < 2000 && !found; ++attempt) {
        t.bearing_deg = (unit(rng) - 0.5) * 100.0;
        found = in_clear_view(base, t.distance_m, t.bearing_deg);
        for (const auto& [bearing, half] : placed) {
          if (std::abs(bearing - t.bearing_deg) < half + half_width + 2.0) found = false;
        }
      }
      if (!found) {
        throw std::runtime_error("bench ranging: no bearing in clear view for a person at " +
                                 std::to_string(distances[i]) + " m in the paper scene");
      }
      placed.emplace_back(t.bearing_deg, half_width);
      t.heading_deg = (unit(rng) - 0.5) * 60.0;
      t.texture = clothing[static_cast<size_t>(unit(rng) * 2.999)];
      scene.targets.push_back(t);
    }
    scene.visible.illuminance_lux =
        std::exp(std::log(300.0) + unit(rng) * (std::log(50000.0) - std::log(300.0)));
    scene.infrared.ambient_c = 0.0 + 30.0 * unit(rng);
    const sim::SimulatedRig simulated(rig, scene, rng());
    sim::FrameSet frames = simulated.allocate();
    simulated.render(0, frames);
    const pl::GridCapture capture =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    // --bound: the same scene without noise (no draw from rng: the trials stay those without).
    std::optional<pl::GridCapture> clean;
    if (opt.bound) {
      const sim::SimulatedRig noiseless(rig, scene, 0, sim::RenderOptions{false, false});
      sim::FrameSet f = noiseless.allocate();
      noiseless.render(0, f);
      clean = pipeline.rectify({f[sim::Slot::visible_left], f[sim::Slot::visible_right],
                                f[sim::Slot::infrared_left], f[sim::Slot::infrared_right]});
    }
    const Eigen::Isometry3d& T_ref_vl =
        simulated.rig().camera(simulated.rig().visible.left).T_ref_cam;
    for (const sim::TargetTruth& truth : simulated.truth(0)) {
      const auto it = std::find_if(scene.targets.begin(), scene.targets.end(),
                                   [&](const sim::Target& t) { return t.id == truth.id; });
      const double nominal = it->distance_m;
      const Eigen::Vector3d eye = T_ref_vl * Eigen::Vector3d::Zero();
      const Eigen::Vector3d to_centre = T_ref_vl * truth.position_m - eye;
      const bool hidden = simulated.trace(eye, to_centre.normalized(), 0).target_id != truth.id;
      double visible_bound = 0, infrared_bound = 0;
      if (clean && !hidden) {
        const Eigen::Vector3d centre = T_ref_vl * truth.position_m;
        visible_bound =
            range_bound_m(pipeline, simulated, truth, centre, pl::Band::visible, *clean, capture);
        infrared_bound =
            range_bound_m(pipeline, simulated, truth, centre, pl::Band::infrared, *clean, capture);
      }
      for (Mode mode : modes) {
        Cell& cell = cells[{nominal, mode}];
        if (hidden) {
          ++cell.hidden;
          continue;
        }
        if (clean) {
          // An unbiased estimate at the bound: a mean |error| of sqrt(2 / pi) sigma. Fused: the
          // two pairs' bounds combined by inverse variance, as their ranges are.
          const double sigma = mode == Mode::visible ? visible_bound
                               : mode == Mode::infrared
                                   ? infrared_bound
                                   : 1.0 / std::sqrt(1.0 / (visible_bound * visible_bound) +
                                                     1.0 / (infrared_bound * infrared_bound));
          if (std::isfinite(sigma)) {
            cell.bound_abs_sum += std::sqrt(2.0 / M_PI) * sigma;
            ++cell.bounds;
          }
        }
        // The box as the pipeline has it: on the visible image for the visible pair, on the
        // infrared one (where the detector finds people) for the infrared pair and for both.
        // The silhouette's box on the grid (what the pipeline's detector finds), on the
        // infrared image where the infrared pair is ranged.
        const cv::Rect box = pl::points_box_on_grid(
            pipeline.geometry(), mode != Mode::visible ? pl::Band::infrared : pl::Band::visible,
            truth.surface_points_m);
        if (box.empty()) {
          ++cell.failures;
          continue;
        }
        const pl::CaptureTarget r = pipeline.range(capture, box, "person", band_choice(mode));
        if (!r.ranged.ok()) {
          ++cell.failures;
          const auto g = pipeline.geometry().ranging(mode == Mode::infrared ? pl::Band::infrared
                                                                            : pl::Band::visible);
          Eigen::Vector2d px;
          double true_disparity = 0;
          rg::project_point(g, g.T_ref_left_rect.inverse() * (T_ref_vl * truth.position_m), px,
                            true_disparity);
          std::ostringstream why;
          why << "box " << box.width << "x" << box.height << " px at (" << box.x << ", " << box.y
              << "), true disparity " << std::fixed << std::setprecision(2) << true_disparity
              << " px: " << r.ranged.range.message;
          cell.why.push_back(why.str());
          continue;
        }
        // From the left visible camera's centre, as the truth.
        const double error = r.ranged.distance_m - truth.distance_m;
        cell.errors.push_back(error);
        cell.within_sigma += std::abs(error) <= r.ranged.range.sigma_m;
        cell.sigma_sum += r.ranged.range.sigma_m;
        if (opt.points) {
          evaluate_points(simulated, truth,
                          pipeline.geometry().ranging(mode == Mode::infrared ? pl::Band::infrared
                                                                             : pl::Band::visible),
                          box, r, person, cell);
        }
      }
    }
    if (!opt.json) {
      std::cerr << "trial " << trial + 1 << "/" << opt.trials << " done ("
                << std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count()
                << " s)\n";
    }
  }

  // Physics: Eq. 2 for 0.1 px of disparity error at the grid's centre resolution.
  auto eq2 = [&](Mode mode, double L) {
    const auto g = pipeline.geometry().ranging(mode == Mode::infrared ? pl::Band::infrared
                                                                      : pl::Band::visible);
    return L * L / (g.grid.intrinsics().f * g.baseline_m) * 0.1;
  };
  std::vector<nlohmann::json> rows;
  for (double distance : distances) {
    for (Mode mode : modes) {
      const Cell& c = cells[{distance, mode}];
      const int n = static_cast<int>(c.errors.size());
      double mean_abs = 0, max_abs = 0, mean_signed = 0;
      for (double e : c.errors) {
        mean_abs += std::abs(e);
        mean_signed += e;
        max_abs = std::max(max_abs, std::abs(e));
      }
      nlohmann::json row{
          {"distance_m", distance},
          {"mode", mode_name(mode)},
          {"trials", opt.trials},
          {"ranged", n},
          {"failures", c.failures},
          {"hidden", c.hidden},
          {"why_not_ranged", c.why},
          {"mean_abs_error_m", n ? nlohmann::json(mean_abs / n) : nlohmann::json()},
          {"mean_signed_error_m", n ? nlohmann::json(mean_signed / n) : nlohmann::json()},
          {"max_abs_error_m", n ? nlohmann::json(max_abs) : nlohmann::json()},
          {"within_1_sigma", n ? nlohmann::json(double(c.within_sigma) / n) : nlohmann::json()},
          {"mean_sigma_m", n ? nlohmann::json(c.sigma_sum / n) : nlohmann::json()},
          {"eq2_error_at_0.1px_m", eq2(mode, distance)}};
      if (opt.points && c.points > 0) {
        const double on = std::max(1, c.on_target);
        const double mean_e = c.disparity_error_sum / on;
        double true_bias = 0;
        for (double e : c.true_disparity_errors) true_bias += e;
        row["points_per_target"] = double(c.points) / std::max(1, n);
        row["on_target_fraction"] = double(c.on_target) / c.points;
        row["on_target_disparity_bias_px"] = mean_e;
        row["on_target_disparity_sd_px"] =
            std::sqrt(std::max(0.0, c.disparity_error_sum2 / on - mean_e * mean_e));
        row["off_target_disparity_vs_centre_px"] =
            c.points > c.on_target
                ? nlohmann::json(c.off_target_error_sum / (c.points - c.on_target))
                : nlohmann::json();
        row["true_centre_offset_m"] = c.centre_offset_sum / on;
        row["bias_with_true_disparities_m"] =
            c.true_disparity_errors.empty()
                ? nlohmann::json()
                : nlohmann::json(true_bias / static_cast<double>(c.true_disparity_errors.size()));
      }
      if (c.bounds > 0) {
        row["bound_mean_abs_m"] = c.bound_abs_sum / c.bounds;
        row["bounds"] = c.bounds;
      }
      const auto paper = paper_error(distance, mode);
      row["paper_abs_error_m"] = paper ? nlohmann::json(*paper) : nlohmann::json();
      rows.push_back(row);
    }
  }
  if (opt.json) {
    for (const auto& r : rows) std::cout << r.dump() << "\n";
    return 0;
  }
  std::cout << "Ranging on the simulated rig, " << opt.trials << " trials per distance, method "
            << opt.method << " (errors vs the true distance of the person's centre)\n";
  std::cout << std::setw(7) << "dist m" << std::setw(10) << "mode" << std::setw(8) << "ranged"
            << std::setw(12) << "mean|err|" << std::setw(10) << "max|err|" << std::setw(10)
            << "bias" << std::setw(10) << "sigma" << std::setw(8) << "in 1s" << std::setw(9)
            << "paper" << std::setw(11) << "Eq2@0.1px" << (opt.bound ? "     bound" : "") << "\n"
            << std::fixed;
  // A number with `p` decimals, "-" for null.
  auto num = [](const nlohmann::json& v, int p) {
    std::ostringstream s;
    if (v.is_null()) return std::string("-");
    s << std::fixed << std::setprecision(p) << v.get<double>();
    return s.str();
  };
  for (const auto& r : rows) {
    std::cout << std::setw(7) << std::setprecision(0) << r["distance_m"].get<double>()
              << std::setw(10) << r["mode"].get<std::string>() << std::setw(8)
              << (std::to_string(r["ranged"].get<int>()) + "/" + std::to_string(opt.trials))
              << std::setw(12) << num(r["mean_abs_error_m"], 3) << std::setw(10)
              << num(r["max_abs_error_m"], 3) << std::setw(10) << num(r["mean_signed_error_m"], 3)
              << std::setw(10) << num(r["mean_sigma_m"], 3) << std::setw(8)
              << num(r["within_1_sigma"], 2) << std::setw(9) << num(r["paper_abs_error_m"], 2)
              << std::setw(11) << num(r["eq2_error_at_0.1px_m"], 3);
    if (opt.bound)
      std::cout << std::setw(10) << num(r.value("bound_mean_abs_m", nlohmann::json()), 3);
    std::cout << "\n";
  }
  bool any_failure = false;
  for (const auto& r : rows) {
    for (const auto& why : r["why_not_ranged"]) {
      if (!any_failure) std::cout << "\nNot ranged:\n";
      any_failure = true;
      std::cout << "  " << r["distance_m"].get<double>() << " m " << r["mode"].get<std::string>()
                << ": " << why.get<std::string>() << "\n";
    }
  }
  if (opt.points) {
    std::cout << "\nKept points against the scene's geometry: points per target, fraction whose "
                 "pixel ray meets the target, their disparity error (mean, sd, px), off-target "
                 "points' disparity minus the target centre's (px), true centre distance minus "
                 "point distance (m), and the bias the same points give with true disparities "
                 "(m)\n";
    std::cout << std::setw(7) << "dist m" << std::setw(10) << "mode" << std::setw(8) << "pts"
              << std::setw(8) << "on" << std::setw(10) << "dbias" << std::setw(9) << "dsd"
              << std::setw(10) << "off-d" << std::setw(10) << "offset" << std::setw(13)
              << "true-d bias"
              << "\n";
    for (const auto& r : rows) {
      if (!r.contains("points_per_target")) continue;
      std::cout << std::setw(7) << std::setprecision(0) << r["distance_m"].get<double>()
                << std::setw(10) << r["mode"].get<std::string>() << std::setw(8)
                << num(r["points_per_target"], 0) << std::setw(8) << num(r["on_target_fraction"], 2)
                << std::setw(10) << num(r["on_target_disparity_bias_px"], 3) << std::setw(9)
                << num(r["on_target_disparity_sd_px"], 3) << std::setw(10)
                << num(r["off_target_disparity_vs_centre_px"], 3) << std::setw(10)
                << num(r["true_centre_offset_m"], 3) << std::setw(13)
                << num(r["bias_with_true_disparities_m"], 3) << "\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND(
    "bench ranging",
    "Table 6 on the simulated rig: ranging error per distance and mode beside the paper's",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--distances", opt->distances, "comma-separated distances, m")
          ->capture_default_str();
      app.add_option("--trials", opt->trials, "scenes rendered (one person per distance each)")
          ->capture_default_str();
      app.add_option("--mode", opt->mode, "all | fused | visible | infrared")
          ->capture_default_str();
      app.add_option("--method", opt->method, "matching: ncc | orb | akaze | sift | sgbm")
          ->capture_default_str();
      app.add_option("--seed", opt->seed, "random seed (bearings, lighting, noise)")
          ->capture_default_str();
      app.add_flag("--json", opt->json,
                   "JSON rows: distance_m, mode, trials, mean_abs_error_m, "
                   "max_abs_error_m, within_1_sigma, ...");
      app.add_flag("--points", opt->points,
                   "also trace every kept point in the simulated scene (evaluation only): "
                   "on-target fraction, disparity error against the true geometry (visible "
                   "and infrared; fused combines those two pairs' ranges)");
      app.add_flag("--bound", opt->bound,
                   "also the least mean |error| each person's pixels allow (the Cramer-Rao bound "
                   "of its silhouette's disparity on noise-free renders, with the rendered "
                   "noise): bound_mean_abs_m");
      app.add_option("--estimate", opt->estimate,
                     "what each pair's range rests on: points | region | both")
          ->capture_default_str();
      thermovis::runtime::add_grid_options(app, opt->grid);
      return [opt] { return run_bench_ranging(*opt); };
    });

}  // namespace
