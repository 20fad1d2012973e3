#include "thermovis/node/service.hpp"

#include <signal.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <map>
#include <opencv2/core/utility.hpp>

#include "thermovis/util/heap.hpp"

namespace thermovis::node {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_stop_signal(int /*signal*/) { g_stop.store(true); }

}  // namespace

void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

bool stop_requested() { return g_stop.load(); }
void request_stop() { g_stop.store(true); }

void add_common_options(CLI::App& app, CommonOptions& options, bool with_rig) {
  if (const char* env = std::getenv("THERMOVIS_DOMAIN"); env != nullptr && *env != '\0') {
    options.domain = std::atoi(env);
  }
  app.add_option("--domain", options.domain, "DDS domain id (default $THERMOVIS_DOMAIN or 0)")
      ->check(CLI::Range(0, 232));
  app.add_option("--profile", options.profile,
                 "DDS participant profile: thermovis_host (shared memory, one host), "
                 "thermovis_loopback (tests), thermovis_udp / thermovis_udp_paced (several "
                 "hosts), thermovis_discovery (discovery server, needs ROS_DISCOVERY_SERVER), "
                 "thermovis_secure (DDS Security)");
  app.add_option("--profiles-file", options.profiles_file, "DDS XML profiles file");
  if (with_rig) app.add_option("--rig", options.rig, "rig YAML (default deploy/rigs/paper.yaml)");
  app.add_option("--frame-transport", options.frame_transport,
                 "where this service reads frames from: plain (the frame topics, by data-sharing "
                 "on the writer's host; the default) or packed (their <topic>/packed twins, "
                 "the pixels only: for a service on another host than the frames' writer)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, transport::FrameTransport>{
              {"plain", transport::FrameTransport::plain},
              {"packed", transport::FrameTransport::packed}},
          CLI::ignore_case));
  app.add_option("--threads", options.threads,
                 "OpenCV worker threads (1: sequential, the default; -1: one per core)")
      ->capture_default_str()
      ->check(CLI::Range(-1, 64));
}

std::unique_ptr<transport::Participant> make_participant(const CommonOptions& options) {
  transport::ParticipantConfig config;
  config.domain_id = options.domain;
  config.profile = options.profile;
  config.profiles_file = options.profiles_file.empty()
                             ? transport::shipped_profile_file(options.profile)
                             : options.profiles_file;
  config.name = options.service;
  config.frame_transport = options.frame_transport;
  return std::make_unique<transport::Participant>(config);
}

int run_service(const CommonOptions& options, const std::function<void()>& body) {
  install_stop_handlers();
  util::keep_freed_heap();
  cv::setNumThreads(options.threads);
  try {
    body();
  } catch (const std::exception& e) {
    std::cerr << options.service << ": error: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}

std::chrono::nanoseconds deadline_from_ms(double milliseconds) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(milliseconds * 1e6));
}

ServiceApp::ServiceApp(const std::string& service, const std::string& description, bool with_rig)
    : CLI::App(service + ": " + description) {
  common.service = service;
  add_common_options(*this, common, with_rig);
}

void ServiceApp::add_deadline_option(const std::string& help) {
  add_option("--deadline-ms", deadline_ms_, help)
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

}  // namespace thermovis::node
