#include "display_session.hpp"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "supervisor.hpp"
#include "thermovis/process/process_group.hpp"
#include "thermovis/transport/participant.hpp"

#ifdef THERMOVIS_HAVE_HTTPLIB
#include <httplib.h>
#endif

namespace thermovis::cli {

namespace {

// The viewer's niceness: a best-effort consumer of the pipeline's results (not idle: it holds
// loans of the fused frames while it copies them, and must not sit on one for long).
constexpr int kDisplayNice = 10;

std::unique_ptr<process::ProcessGroup> start_group(process::ServiceSpec spec,
                                                   const std::string& log_dir) {
  process::Manifest manifest{spec.name, {std::move(spec)}};
  auto group = std::make_unique<process::ProcessGroup>(
      manifest, process::ProcessGroupOptions{{}, log_dir, {}});
  group->start_all();
  return group;
}

#ifdef THERMOVIS_HAVE_HTTPLIB
// GET `path` of the viewer on this host; empty unless it answered 200.
std::string get(int port, const std::string& path) {
  httplib::Client client("127.0.0.1", port);
  client.set_connection_timeout(1, 0);
  client.set_read_timeout(5, 0);
  const auto response = client.Get(path.c_str());
  return response && response->status == 200 ? response->body : std::string();
}
#else
std::string get(int, const std::string&) { return {}; }
#endif

}  // namespace

DisplaySession::DisplaySession(const SessionOptions& session, const DisplayOptions& options)
    : options_(options) {
  const auto vars = supervisor::default_vars(
      session.domain, session.profile.empty() ? transport::kHostProfile : session.profile, "");
  process::ServiceSpec view;
  view.name = "view";
  view.command = {vars.at("bin") + "/thermovis-view",
                  "--domain",
                  vars.at("domain"),
                  "--profile",
                  vars.at("profile"),
                  "--port",
                  std::to_string(options.port)};
  view.nice = kDisplayNice;
  viewer_ = start_group(view, session.log_dir);
  if (options.browser.empty()) return;
#ifndef THERMOVIS_HAVE_HTTPLIB
  throw std::runtime_error("--browser: this thermovis was built without cpp-httplib");
#endif
  // The page must answer before the browser opens it: a browser shows an error page once and
  // does not try again.
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (get(options.port, "/").empty()) {
    if (std::chrono::steady_clock::now() > until) {
      throw std::runtime_error("thermovis-view did not answer on " + url() +
                               " within 20 s (log: " + viewer_->status("view").log.string() + ")");
    }
    viewer_->poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  process::ServiceSpec browser;
  browser.name = "browser";
  const std::filesystem::path profile = std::filesystem::path(session.log_dir) / "browser-profile";
  std::filesystem::remove_all(profile);
  browser.command = {options.browser,
                     "--headless=new",
                     "--disable-gpu",
                     "--no-first-run",
                     "--no-default-browser-check",
                     "--mute-audio",
                     "--user-data-dir=" + profile.string()};
  // Chromium refuses to run as root with its sandbox.
  if (::geteuid() == 0) browser.command.push_back("--no-sandbox");
  browser.command.push_back(url());
  browser.restart = process::RestartPolicy::never;
  // Only on CPU time the pipeline leaves: Chromium sets its own processes' niceness (to -8 for
  // some, as root), so a niceness alone does not hold it back.
  browser.idle = true;
  browser_ = start_group(browser, session.log_dir);
}

DisplaySession::~DisplaySession() { stop(); }

std::string DisplaySession::url() const {
  return "http://127.0.0.1:" + std::to_string(options_.port) + "/";
}

void DisplaySession::poll() {
  if (viewer_) viewer_->poll();
  if (browser_) browser_->poll();
}

void DisplaySession::stop() {
  if (browser_) browser_->stop_all();
  if (viewer_) viewer_->stop_all();
}

std::vector<ProcessCpu> DisplaySession::cpu() const {
  std::vector<ProcessCpu> out = marks_.since(viewer_->status());
  if (browser_) {
    for (const ProcessCpu& p : marks_.since(browser_->status())) out.push_back(p);
  }
  return out;
}

void DisplaySession::reset_statistics() {
  std::vector<process::ServiceStatus> services = viewer_->status();
  if (browser_) {
    for (const auto& status : browser_->status()) services.push_back(status);
  }
  marks_.mark(services);
}

nlohmann::json DisplaySession::latency() const {
  const std::string body = get(options_.port, "/display-latency.json");
  return body.empty() ? nlohmann::json() : nlohmann::json::parse(body, nullptr, false);
}

}  // namespace thermovis::cli
