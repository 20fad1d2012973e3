// thermovis-supervisor: runs the pipeline's services, restarts them, measures latency.
#include <CLI/CLI.hpp>
#include <iostream>
#include <thread>

#include "supervisor.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/process/manifest_io.hpp"
#include "thermovis/runtime/rig_io.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-supervisor",
                       "starts, watches and restarts the pipeline's services");
  std::string manifest_path, scene, log_dir = "/tmp/thermovis-logs";
  std::vector<std::string> extra_vars;
  double seconds = 0.0;
  bool json = false;
  supervisor::SupervisorConfig config;
  app.add_option("--manifest", manifest_path, "pipeline manifest (default deploy/pipeline.yaml)");
  app.add_option("--scene", scene,
                 "simulated scene for the manifest's ${scene} (default deploy/scenes/paper.yaml)");
  app.add_option("--var", extra_vars, "KEY=VALUE for the manifest's ${KEY} (repeatable)");
  app.add_option("--seconds", seconds, "stop after this long (0: until SIGINT/SIGTERM)")
      ->capture_default_str();
  app.add_option("--log-dir", log_dir, "folder of the services' logs")->capture_default_str();
  app.add_option("--latency-deadline-ms", config.latency_deadline_ms, "capture-to-output budget")
      ->capture_default_str();
  app.add_flag("--json", json, "print the final summary as one JSON object");
  CLI11_PARSE(app, argc, argv);

  node::install_stop_handlers();
  try {
    const auto manifest =
        process::load_manifest(manifest_path.empty() ? runtime::shipped_file("pipeline.yaml")
                                                     : std::filesystem::path(manifest_path));
    config.vars = supervisor::default_vars(app.common.domain, app.common.profile, scene);
    for (const std::string& item : extra_vars) {
      const auto eq = item.find('=');
      if (eq == std::string::npos || eq == 0)
        throw std::invalid_argument("--var needs KEY=VALUE, got '" + item + "'");
      config.vars[item.substr(0, eq)] = item.substr(eq + 1);
    }
    config.log_dir = log_dir;
    auto participant = node::make_participant(app.common);
    supervisor::Supervisor sup(*participant, manifest, config);
    sup.start();
    const auto start = std::chrono::steady_clock::now();
    while (!node::stop_requested()) {
      sup.step();
      if (seconds > 0 &&
          std::chrono::steady_clock::now() - start > std::chrono::duration<double>(seconds))
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    sup.stop();
    const auto summary = sup.summary();
    std::cout << (json ? supervisor::summary_json(summary) + "\n"
                       : supervisor::summary_text(summary, config.latency_deadline_ms));
  } catch (const std::exception& e) {
    std::cerr << "thermovis-supervisor: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
