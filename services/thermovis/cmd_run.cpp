// thermovis run: the whole pipeline on the simulated rig, one line per range and per obstacle with
// its truth and error, and the latency summary at the end. --view adds the live display
// (thermovis-view).
#include <chrono>
#include <iostream>
#include <memory>
#include <thread>

#include "command.hpp"
#include "display_session.hpp"
#include "pipeline_session.hpp"
#include "thermovis/node/service.hpp"

namespace {

using thermovis::cli::PipelineSession;

struct Options {
  thermovis::cli::SessionOptions session;
  double seconds = 10.0;
  bool json = false;
  bool view = false;
  int view_port = 8090;
};

int run_pipeline(Options& opt) {
  thermovis::node::install_stop_handlers();
  if (opt.view) thermovis::cli::with_display(opt.session);
  PipelineSession session(opt.session);
  session.start();
  if (!opt.json) {
    std::cout << "thermovis run: pipeline started on DDS domain " << opt.session.domain
              << ", logs in " << opt.session.log_dir << " (Ctrl-C stops)" << std::endl;
  }
  std::unique_ptr<thermovis::cli::DisplaySession> viewer;
  if (opt.view) {
    viewer = std::make_unique<thermovis::cli::DisplaySession>(
        opt.session, thermovis::cli::DisplayOptions{opt.view_port, ""});
    // On stderr with --json, so that stdout stays JSON lines.
    (opt.json ? std::cerr : std::cout)
        << "thermovis run: live display at " << viewer->url() << std::endl;
  }
  const auto start = std::chrono::steady_clock::now();
  while (!thermovis::node::stop_requested()) {
    for (const auto& checked : session.step()) {
      std::cout << (opt.json ? thermovis::cli::range_json(checked)
                             : thermovis::cli::range_line(checked))
                << std::endl;
    }
    for (const auto& checked : session.step_obstacles()) {
      if (opt.json) {
        std::cout << thermovis::cli::obstacle_json(checked) << std::endl;
      } else if (!checked.obstacle.has_target()) {  // a ranged target has its range line
        std::cout << thermovis::cli::obstacle_line(checked) << std::endl;
      }
    }
    if (opt.seconds > 0 &&
        std::chrono::steady_clock::now() - start > std::chrono::duration<double>(opt.seconds))
      break;
    if (viewer) viewer->poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (viewer) viewer->stop();
  session.stop();
  const auto latency = session.latency();
  const auto errors = session.errors();
  const auto obstacles = session.obstacle_errors();
  if (opt.json) {
    std::cout << thermovis::cli::summary_json(latency, errors, &obstacles).dump() << std::endl;
  } else {
    std::cout << thermovis::supervisor::summary_text(latency, session.deadline_ms())
              << thermovis::cli::errors_text(errors)
              << thermovis::cli::obstacle_errors_text(obstacles);
  }
  return latency.frames > 0 ? 0 : 2;
}

THERMOVIS_COMMAND("run", "the whole pipeline on the simulated rig: live ranges, truth, latency",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<Options>();
                    thermovis::cli::add_session_options(app, opt->session);
                    // The last --seconds given wins (deploy/run.sh passes a default first).
                    app.add_option("--seconds", opt->seconds, "run this long (0: until Ctrl-C)")
                        ->capture_default_str()
                        ->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
                    app.add_flag(
                        "--json", opt->json,
                        "ranges and obstacles as JSON lines, the summary as the last line");
                    app.add_flag("--view", opt->view,
                                 "also start the live display (thermovis-view) and print its URL");
                    app.add_option("--view-port", opt->view_port, "HTTP port of the display")
                        ->capture_default_str()
                        ->check(CLI::Range(1, 65535));
                    return [opt] { return run_pipeline(*opt); };
                  });

}  // namespace
