// thermovis detect-eval: person detection measured on a folder of annotated frames (infrared/,
// optional visible/, boxes.json): precision, recall and VOC AP at an IoU threshold, overall and
// per person-box height, and ms per image. A frame that cannot be used is reported (naming the
// file and the entry) and the rest of the folder is still evaluated.
#include <chrono>
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "command.hpp"
#include "detect_options.hpp"
#include "scene_arg.hpp"
#include "thermovis/detect/evaluation.hpp"
#include "thermovis/pipeline/capture_pipeline.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace {

namespace dt = thermovis::detect;
using Clock = std::chrono::steady_clock;

struct Options {
  std::string dir;
  std::string scene, rig;
  int scene_frames = 10, frame_step = 10;
  std::uint64_t seed = 1;
  std::string frames = "eval";
  double iou = 0.5;
  bool json = false;
  thermovis::cli::DetectorFlags detector;
};

struct Bucket {
  const char* name;
  double min_px, max_px;
};
constexpr double kInf = std::numeric_limits<double>::infinity();
// Person box heights (px): far, middle and near people.
constexpr Bucket kBuckets[] = {{"<30", 0, 30}, {"30-80", 30, 80}, {">80", 80, kInf}};

nlohmann::json figures_json(const dt::Figures& f) {
  return {
      {"persons", f.persons}, {"detections", f.detections}, {"true_positives", f.true_positives},
      {"ap50", f.ap},         {"precision", f.precision},   {"recall", f.recall}};
}

// Captures of a simulated scene rectified onto the pipeline's grid (as the services do), the
// detector run on the grid with its ground prior, against the simulator's person silhouettes
// on the grid (in the band the detector looks at: the visible one for --band visible).
std::vector<dt::FrameResult> simulated_results(const Options& opt, dt::PersonDetector& detector,
                                               double& ms) {
  namespace pl = thermovis::pipeline;
  namespace sim = thermovis::sim;
  if (opt.scene_frames < 1) throw std::invalid_argument("--scene-frames: at least 1");
  if (opt.frame_step < 1) throw std::invalid_argument("--frame-step: at least 1");
  const auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  const sim::SimulatedRig simulated(
      rig, thermovis::runtime::load_scene(thermovis::cli::resolve_scene(opt.scene)), opt.seed);
  pl::CapturePipeline pipeline(rig);
  const thermovis::camera::RectifiedCamera grid(pipeline.geometry().grid);
  const dt::Band band = detector.options().band;
  const pl::Band truth_band = band == dt::Band::visible ? pl::Band::visible : pl::Band::infrared;
  const cv::Rect image(cv::Point(0, 0), pipeline.geometry().grid_size());
  sim::FrameSet frames = simulated.allocate();
  std::vector<dt::FrameResult> results;
  for (int k = 0; k < opt.scene_frames; ++k) {
    const int frame = k * opt.frame_step;
    simulated.render(frame, frames);
    const pl::GridCapture capture =
        pipeline.rectify({frames[sim::Slot::visible_left], frames[sim::Slot::visible_right],
                          frames[sim::Slot::infrared_left], frames[sim::Slot::infrared_right]});
    const auto t0 = Clock::now();
    dt::FrameResult r;
    r.detections =
        detector.detect(band == dt::Band::visible ? cv::Mat() : capture.infrared_left,
                        band == dt::Band::infrared ? cv::Mat() : capture.visible_left, &grid);
    ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    for (const auto& t : simulated.truth(frame)) {
      if (t.cls != sim::TargetClass::person) continue;
      const cv::Rect box =
          pl::points_box_on_grid(pipeline.geometry(), truth_band, t.surface_points_m) & image;
      if (!box.empty()) r.persons.push_back(box);
    }
    results.push_back(std::move(r));
  }
  return results;
}

int run_detect_eval(const Options& opt) {
  if (opt.frames != "eval" && opt.frames != "train" && opt.frames != "all")
    throw std::invalid_argument("--frames: expected eval, train or all");
  if (!(opt.iou > 0.0 && opt.iou <= 1.0)) throw std::invalid_argument("--iou in (0, 1]");
  if (opt.dir.empty() == opt.scene.empty())
    throw std::invalid_argument("give --dir (annotated frames) or --scene (simulated), one");
  dt::PersonDetector detector = opt.detector.make();
  const dt::Band band = detector.options().band;
  std::vector<std::string> errors;
  std::vector<dt::FrameResult> results;
  double ms = 0.0;
  const dt::AnnotatedSet set =
      opt.dir.empty() ? dt::AnnotatedSet{} : dt::load_annotated_set(opt.dir);
  errors = set.errors;
  if (!opt.scene.empty()) results = simulated_results(opt, detector, ms);
  for (const auto& frame : set.frames) {
    if (opt.frames != "all" && dt::is_training_frame(frame.name) != (opt.frames == "train"))
      continue;
    dt::FrameImages images;
    try {
      images = dt::load_frame_images(frame, band != dt::Band::infrared);
    } catch (const std::exception& e) {
      errors.push_back(e.what());
      continue;
    }
    if (band == dt::Band::visible) images.infrared.release();
    const auto t0 = Clock::now();
    dt::FrameResult r;
    r.detections = detector.detect(images.infrared, images.visible, nullptr);
    ms += std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    r.persons = frame.persons;
    r.dont_care = frame.dont_care;
    results.push_back(std::move(r));
  }
  for (const auto& e : errors) std::cerr << "detect-eval: " << e << "\n";
  const std::string source = opt.dir.empty() ? "scene " + opt.scene : opt.dir;
  if (results.empty()) throw std::runtime_error(source + ": no frame could be evaluated");

  const dt::Figures all = dt::evaluate(results, opt.iou);
  const double ms_per_image = ms / static_cast<double>(results.size());
  nlohmann::json by_height = nlohmann::json::array();
  for (const auto& b : kBuckets) {
    nlohmann::json row = figures_json(dt::evaluate(results, opt.iou, b.min_px, b.max_px));
    row["bucket"] = b.name;
    by_height.push_back(row);
  }
  std::string method = dt::band_name(band);
  if (band != dt::Band::infrared)
    method += " (visible: " + dt::visible_method_name(detector.options().visible_method) + ")";
  if (opt.json) {
    nlohmann::json out = figures_json(all);
    if (opt.dir.empty()) {
      out["scene"] = opt.scene;
      out["seed"] = opt.seed;
    } else {
      out["dir"] = opt.dir;
    }
    out["band"] = method;
    out["frames"] = opt.dir.empty() ? std::string("simulated") : opt.frames;
    out["iou"] = opt.iou;
    out["images"] = results.size();
    out["ms_per_image"] = ms_per_image;
    out["by_height"] = by_height;
    out["errors"] = errors;
    std::cout << out.dump() << "\n";
    return 0;
  }
  std::cout << source << ": " << results.size() << " images ("
            << (opt.dir.empty() ? std::string("simulated, on the pipeline grid")
                                : opt.frames + " frames")
            << "), " << all.persons << " persons, band " << method << ", IoU " << opt.iou << "\n"
            << std::fixed;
  std::cout << std::left << std::setw(10) << "height" << std::right << std::setw(9) << "persons"
            << std::setw(8) << "boxes" << std::setw(8) << "AP" << std::setw(11) << "precision"
            << std::setw(8) << "recall\n";
  auto print = [](const std::string& name, const nlohmann::json& r) {
    std::cout << std::left << std::setw(10) << name << std::right << std::setw(9)
              << r["persons"].get<int>() << std::setw(8) << r["detections"].get<int>()
              << std::setprecision(3) << std::setw(8) << r["ap50"].get<double>() << std::setw(11)
              << r["precision"].get<double>() << std::setw(8) << r["recall"].get<double>() << "\n";
  };
  print("all", figures_json(all));
  for (const auto& row : by_height) print(row["bucket"].get<std::string>() + " px", row);
  std::cout << std::setprecision(1) << ms_per_image << " ms per image (detection only)\n";
  if (!errors.empty()) std::cout << errors.size() << " frames left out (see stderr)\n";
  return 0;
}

THERMOVIS_COMMAND(
    "detect-eval",
    "Person detection on a folder of annotated frames: precision, recall, VOC AP per band and "
    "box height, ms per image",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--dir", opt->dir,
                     "folder with infrared/, optional visible/ and boxes.json (0-based pixel "
                     "edges [x0, y0, x1, y1])");
      app.add_option("--scene", opt->scene,
                     "instead of --dir: a simulated scene (shipped name or YAML), its captures "
                     "rectified onto the pipeline grid, against the simulator's people");
      app.add_option("--rig", opt->rig, "--scene: rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--scene-frames", opt->scene_frames, "--scene: captures evaluated")
          ->capture_default_str();
      app.add_option("--frame-step", opt->frame_step, "--scene: frames between two captures")
          ->capture_default_str();
      app.add_option("--seed", opt->seed, "--scene: noise seed")->capture_default_str();
      app.add_option("--frames", opt->frames,
                     "eval, train or all. A frame trains (detect-train) when the FNV-1a 32-bit "
                     "hash of its name less the last character is even (ten consecutive "
                     "frames stay on one side), else it evaluates: the shipped model's figures "
                     "are those of the eval frames")
          ->capture_default_str();
      app.add_option("--iou", opt->iou, "IoU a detection needs with a person box")
          ->capture_default_str();
      app.add_flag("--json", opt->json, "one JSON object");
      opt->detector.add_to(app);
      return [opt] { return run_detect_eval(*opt); };
    });

}  // namespace
