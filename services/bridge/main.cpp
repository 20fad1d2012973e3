// thermovis-bridge: raw stereo frames (visible pair, infrared pair) from a source onto DDS.
#include <CLI/CLI.hpp>
#include <iostream>

#include "bridge_node.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/runtime/rig_io.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  CLI::App app{"thermovis-bridge: publishes raw visible and infrared stereo frames"};
  node::CommonOptions common;
  common.service = "thermovis-bridge";
  bridge::SourceOptions source;
  bridge::BridgeConfig config;
  double deadline_ms = 20.0;
  node::add_common_options(app, common);
  app.add_option("--source", source.kind, "sim | v4l2")->capture_default_str();
  app.add_option("--scene", source.scene, "sim: scene YAML (default deploy/scenes/paper.yaml)");
  app.add_option("--seed", source.seed, "sim: noise seed")->capture_default_str();
  app.add_option("--devices", source.devices, "v4l2: four devices VL,VR,IL,IR");
  app.add_option("--rate", config.rate_hz, "captures per second")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--frames", config.frames, "stop after N captures (0: run until stopped)")
      ->capture_default_str();
  app.add_option("--deadline-ms", deadline_ms, "DEADLINE QoS period of the frame topics")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  config.deadline = std::chrono::nanoseconds(static_cast<std::int64_t>(deadline_ms * 1e6));

  node::install_stop_handlers();
  try {
    const auto rig =
        runtime::load_rig(common.rig.empty() ? runtime::default_rig_path() : common.rig);
    auto participant = node::make_participant(common);
    bridge::BridgeNode bridge(*participant, bridge::make_source(source, rig), config,
                              common.service);
    bridge.run();
    const auto stats = bridge.stats();
    std::cerr << "thermovis-bridge: published " << stats.published << ", dropped " << stats.dropped
              << ", bad " << stats.bad << "\n";
  } catch (const std::exception& e) {
    std::cerr << "thermovis-bridge: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
