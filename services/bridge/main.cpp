// thermovis-bridge: raw stereo frames (visible pair, infrared pair) from a source onto DDS.
#include <CLI/CLI.hpp>
#include <chrono>
#include <iostream>

#include "bridge_node.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/runtime/rig_io.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-bridge", "publishes raw visible and infrared stereo frames");
  bridge::SourceOptions source;
  bridge::BridgeConfig config;
  app.add_option("--source", source.kind,
                 "where captures come from: sim (the simulated rig), files (a rendered folder, "
                 "--dir), v4l2 (cameras, --devices), fpga-dma (the FPGA's capture ring, --ring)")
      ->capture_default_str()
      ->check(CLI::IsMember({"sim", "files", "v4l2", "fpga-dma"}));
  app.add_option("--scene", source.scene, "sim: scene YAML (default deploy/scenes/paper.yaml)");
  app.add_option("--seed", source.seed, "sim: noise seed")->capture_default_str();
  app.add_option("--prerender", source.prerender,
                 "sim: cycle through N captures (0: render each capture live), rendered once in "
                 "the background while the first ones go out rendered live. A capture then "
                 "costs a copy instead of a render (~20 ms of CPU for the street scene), but "
                 "moving targets repeat every N captures and N captures stay in memory (~15.6 MB "
                 "each for the paper's rig)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sim-cache", source.sim_cache,
                 "sim: folder of the simulator's set-up (the traced static scene and noise "
                 "tables), kept between runs so that a restarted bridge starts in a fraction of a "
                 "second instead of seconds (~200 MB per rig, scene and seed, the 3 newest kept): "
                 "auto ($XDG_CACHE_HOME/thermovis, else ~/.cache/thermovis), a folder, or none")
      ->capture_default_str();
  app.add_option("--dir", source.directory,
                 "files: a folder written by `thermovis scene render --out` (numbered frame "
                 "subfolders of visible_left/right.png, infrared_left/right.png)");
  app.add_flag(
      "--no-loop", [&source](std::int64_t) { source.loop = false; },
      "files: stop at the last frame instead of starting again");
  app.add_flag("--preload", source.preload,
               "files: decode every frame at start and keep it in memory (~15.6 MB per frame for "
               "the paper's rig). Without it each capture decodes four PNGs (~200 ms of CPU at "
               "the paper's resolution), and captures that fall behind --rate are skipped");
  app.add_option("--devices", source.devices, "v4l2: four devices VL,VR,IL,IR");
  app.add_option("--ring", source.ring,
                 "fpga-dma: the capture ring written by the FPGA or thermovis-fpga-emu (a file, "
                 "e.g. /dev/shm/thermovis-ring, or shm:NAME); the FPGA sets the pace");
  app.add_option("--rate", config.rate_hz, "captures per second (not for fpga-dma)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--frames", config.frames,
                 "stop after N captures (0: run until stopped or a --no-loop folder ends)")
      ->capture_default_str();
  app.add_deadline_option("DEADLINE QoS period of the frame topics");
  CLI11_PARSE(app, argc, argv);
  config.deadline = app.deadline();

  return node::run_service(app.common, [&] {
    // Where the start-up goes (a restarted bridge is the pipeline's outage): logged once.
    using Clock = std::chrono::steady_clock;
    const auto ms = [](Clock::time_point a, Clock::time_point b) {
      return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(b - a).count());
    };
    const auto start = Clock::now();
    const auto rig = runtime::load_rig_or_default(app.common.rig);
    source.rig_file = app.common.rig.empty() ? runtime::default_rig_path() : app.common.rig;
    const auto rig_loaded = Clock::now();
    auto participant = node::make_participant(app.common);
    const auto joined = Clock::now();
    auto frames = bridge::make_source(source, rig);
    const auto source_ready = Clock::now();
    bridge::BridgeNode bridge(*participant, std::move(frames), config, app.common.service);
    std::cerr << app.common.service << ": ready " << ms(start, Clock::now())
              << " ms after main: rig " << ms(start, rig_loaded) << " ms, DDS participant "
              << ms(rig_loaded, joined) << " ms, source " << ms(joined, source_ready)
              << " ms, writers and health " << ms(source_ready, Clock::now()) << " ms" << std::endl;
    bridge.run();
    const auto stats = bridge.stats();
    std::cerr << "thermovis-bridge: published " << stats.published << ", dropped " << stats.dropped
              << ", bad " << stats.bad << ", skipped by the source " << stats.source_skipped
              << "\n";
  });
}
