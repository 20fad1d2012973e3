// thermovis scene render: renders a scene through the rig's four cameras to PNG files, with
// ground truth (targets' 3-D positions, distances and boxes) per frame.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "command.hpp"
#include "scene_arg.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace {

namespace fs = std::filesystem;
using thermovis::sim::Slot;

struct Options {
  std::string scene;
  std::string rig;
  std::string out;
  int frames = 1;
  std::int64_t start = 0;
  std::uint64_t seed = 1;
  bool no_noise = false;
  bool json = false;
};

using thermovis::cli::resolve_scene;

nlohmann::json truth_json(const thermovis::sim::SimulatedRig& sim, std::int64_t frame,
                          std::uint64_t seed) {
  nlohmann::json targets = nlohmann::json::array();
  for (const auto& t : sim.truth(frame)) {
    nlohmann::json boxes = nlohmann::json::object();
    for (int i = 0; i < thermovis::sim::kSlotCount; ++i) {
      const auto& box = t.boxes[static_cast<std::size_t>(i)];
      boxes[to_string(static_cast<Slot>(i))] =
          box ? nlohmann::json{box->x_min, box->y_min, box->x_max, box->y_max} : nlohmann::json();
    }
    targets.push_back({{"id", t.id},
                       {"class", to_string(t.cls)},
                       {"position_m", {t.position_m.x(), t.position_m.y(), t.position_m.z()}},
                       {"distance_m", t.distance_m},
                       {"boxes", boxes}});
  }
  return {{"frame", frame},
          {"time_s", static_cast<double>(frame) / sim.scene().frame_rate_hz},
          {"scene", sim.scene().name},
          {"rig", sim.rig().name},
          {"seed", seed},
          {"frame_of_positions", sim.rig().visible.left},
          {"box_format", "[x_min, y_min, x_max, y_max] px, raw image, pixel centres at integers"},
          {"targets", targets}};
}

int run_scene_render(const Options& opt) {
  if (opt.frames < 1) throw std::invalid_argument("--frames must be at least 1");
  const fs::path scene_path = resolve_scene(opt.scene);
  auto scene = thermovis::runtime::load_scene(scene_path);
  auto rig = thermovis::runtime::load_rig_or_default(opt.rig);
  thermovis::sim::RenderOptions render_options;
  render_options.temporal_noise = !opt.no_noise;
  render_options.fixed_pattern = !opt.no_noise;
  const auto t_setup = std::chrono::steady_clock::now();
  const thermovis::sim::SimulatedRig sim(std::move(rig), std::move(scene), opt.seed,
                                         render_options);
  const double setup_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_setup).count();
  if (!opt.json) {
    std::cout << "scene " << sim.scene().name << " (" << scene_path.string() << "), rig "
              << sim.rig().name << ", seed " << opt.seed << ": static scene rendered in "
              << std::fixed << std::setprecision(0) << setup_ms << " ms\n";
  }
  thermovis::sim::FrameSet frames = sim.allocate();
  for (int n = 0; n < opt.frames; ++n) {
    const std::int64_t frame = opt.start + n;
    const auto t0 = std::chrono::steady_clock::now();
    sim.render(frame, frames);
    const double render_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::ostringstream name;
    name << std::setw(6) << std::setfill('0') << frame;
    const fs::path dir = fs::path(opt.out) / name.str();
    fs::create_directories(dir);
    nlohmann::json files = nlohmann::json::object();
    for (int i = 0; i < thermovis::sim::kSlotCount; ++i) {
      const std::string camera = to_string(static_cast<Slot>(i));
      const fs::path file = dir / (camera + ".png");
      if (!cv::imwrite(file.string(), frames.images[static_cast<std::size_t>(i)]))
        throw std::runtime_error("cannot write " + file.string());
      files[camera] = file.string();
    }
    const fs::path truth_file = dir / "truth.json";
    std::ofstream truth_out(truth_file);
    if (!truth_out) throw std::runtime_error("cannot write " + truth_file.string());
    const nlohmann::json truth = truth_json(sim, frame, opt.seed);
    truth_out << truth.dump(2) << "\n";
    if (opt.json) {
      std::cout << nlohmann::json{{"frame", frame},
                                  {"render_ms", render_ms},
                                  {"images", files},
                                  {"truth", truth_file.string()}}
                       .dump()
                << "\n";
    } else {
      std::cout << "frame " << frame << ": rendered in " << std::setprecision(1) << render_ms
                << " ms, " << truth["targets"].size() << " targets -> " << dir.string() << "\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND(
    "scene render",
    "Render a scene through the rig's four cameras (PNG images + truth.json per frame)",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      app.add_option("--scene", opt->scene,
                     "scene YAML, or the name of a shipped scene (paper, night, street)")
          ->required();
      app.add_option("--rig", opt->rig, "rig YAML (default: deploy/rigs/paper.yaml)");
      app.add_option("--frames", opt->frames, "number of frames to render")->capture_default_str();
      app.add_option("--start", opt->start, "index of the first frame (time = index / rate)")
          ->capture_default_str();
      app.add_option("--out", opt->out, "output folder (one subfolder per frame)")->required();
      app.add_option("--seed", opt->seed, "noise seed")->capture_default_str();
      app.add_flag("--no-noise", opt->no_noise, "no temporal or fixed-pattern noise");
      app.add_flag("--json", opt->json, "print one JSON object per frame");
      return [opt] { return run_scene_render(*opt); };
    });

}  // namespace
