#pragma once
// What every thermovis service shares: the stop flag its signal handlers set, the options every
// service takes (domain, DDS profile, rig) and the per-stage time stamps it appends.
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "thermovis/common.h"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"

namespace thermovis::node {

// SIGINT and SIGTERM set the flag (the handler does nothing else); services poll it.
void install_stop_handlers();
bool stop_requested();
void request_stop();  // e.g. from a test harness or after a fatal error

struct CommonOptions {
  std::string service;  // e.g. "thermovis-range" (health key)
  int domain = 0;       // DDS domain; $THERMOVIS_DOMAIN when set
  std::string profile = transport::kHostProfile;
  std::filesystem::path profiles_file;  // empty: the shipped file of `profile`
  std::filesystem::path rig;            // empty: runtime::default_rig_path()
  // OpenCV worker threads. 1 (sequential) by default: the pipeline's processes already share
  // the cores, and idle OpenCV/TBB workers spin between parallel regions, burning the CPU the
  // other services need.
  int threads = 1;
  // Frames from the plain topics or their packed twins (another host than their writer's).
  transport::FrameTransport frame_transport = transport::FrameTransport::plain;
};

// Adds --domain, --profile, --profiles-file, --frame-transport, --threads and, for a service that
// reads the rig (bridge, rectify-fuse; the others take the geometry from thermovis/geometry),
// --rig.
void add_common_options(CLI::App& app, CommonOptions& options, bool with_rig = true);

std::unique_ptr<transport::Participant> make_participant(const CommonOptions& options);

// A service's main after option parsing: installs the stop handlers, sets OpenCV's threads,
// runs `body` and turns an exception into "<service>: error: <what>" on stderr and exit code 1
// (0 otherwise).
int run_service(const CommonOptions& options, const std::function<void()>& body);

// run_service for a node built as Node(participant, config, options.service): makes the DDS
// participant and the node, runs the node until a stop is requested and hands its stats() to
// `report` (the exit summary line).
template <typename Node, typename Config, typename Report>
int run_node(const CommonOptions& options, const Config& config, Report report) {
  return run_service(options, [&] {
    auto participant = make_participant(options);
    Node node(*participant, config, options.service);
    node.run();
    report(node.stats());
  });
}

// A DEADLINE period given in milliseconds on a command line.
std::chrono::nanoseconds deadline_from_ms(double milliseconds);

// A service's command line: a CLI app described as "<service>: <description>", with the options
// every service takes (add_common_options) already added to `common`.
class ServiceApp : public CLI::App {
 public:
  ServiceApp(const std::string& service, const std::string& description, bool with_rig = true);
  // Adds --deadline-ms (default transport::kDefaultFrameDeadline, 1.5 periods of 50 Hz frames),
  // described by `help`; deadline() gives it after parsing.
  void add_deadline_option(const std::string& help);
  std::chrono::nanoseconds deadline() const { return deadline_from_ms(deadline_ms_); }

  CommonOptions common;

 private:
  double deadline_ms_ =
      std::chrono::duration<double, std::milli>(transport::kDefaultFrameDeadline).count();
};

}  // namespace thermovis::node
