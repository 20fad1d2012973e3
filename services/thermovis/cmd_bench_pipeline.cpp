// thermovis bench pipeline: every service at the capture rate on full-resolution simulated
// frames; end-to-end and per-stage latency, CPU and memory per process, drops, deadline misses
// and the ranging error against the simulated truth, after a warm-up. With --external-readers N
// the same again with N other DDS applications reading every frame topic, beside the run
// without them.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "capture_floor.hpp"
#include "command.hpp"
#include "display_session.hpp"
#include "pipeline_session.hpp"
#include "thermovis/metrics/percentile.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/process/host_stalls.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

struct Options {
  thermovis::cli::SessionOptions session;
  double seconds = 30.0;
  double warmup_s = 5.0;
  bool json = false;
  std::vector<std::string> kill;  // services to kill (SIGKILL) once each during the measurement
  bool view = false;              // the live display beside the pipeline (implied by a browser)
  thermovis::cli::DisplayOptions display;
  int external_readers = 0;  // other applications reading every frame topic (second measurement)
  int external_hold_ms = 200;
  bool host_probe = true;  // the machine's stalls beside the latencies (host_stalls.hpp)
};

// Other DDS applications reading every frame topic (build/bin/external_reader: Fast DDS's
// default QoS, data-sharing from the writers' pools), in turn idle (matched, never taking), slow
// (each frame held on its loan external_hold_ms) and crashing (SIGKILLed while holding loans,
// a third of the way into the measurement). Killed when this goes.
class ExternalReaders {
 public:
  ExternalReaders(int count, int domain, int hold_ms, double crash_after_s) {
    const std::filesystem::path exe =
        std::filesystem::canonical("/proc/self/exe").parent_path() / "external_reader";
    if (!std::filesystem::exists(exe)) {
      throw std::runtime_error(exe.string() + " not found (built with the benchmarks)");
    }
    static const char* const kModes[] = {"idle", "slow", "crash"};
    for (int i = 0; i < count; ++i) {
      const std::string mode = kModes[i % 3];
      ++per_mode_[mode];
      std::vector<std::string> args{exe.string(),
                                    "--domain",
                                    std::to_string(domain),
                                    "--mode",
                                    mode,
                                    "--hold-ms",
                                    std::to_string(hold_ms),
                                    "--crash-after-s",
                                    std::to_string(crash_after_s)};
      for (const char* t :
           {thermovis::transport::topics::kVisibleFrames,
            thermovis::transport::topics::kInfraredFrames,
            thermovis::transport::topics::kRectifiedVisible,
            thermovis::transport::topics::kRectifiedInfrared, thermovis::transport::topics::kFused})
        args.emplace_back(t);
      const pid_t pid = ::fork();
      if (pid < 0) throw std::runtime_error("fork failed");
      if (pid == 0) {
        std::vector<char*> argv;
        for (auto& a : args) argv.push_back(a.data());
        argv.push_back(nullptr);
        // Its output would mix with the benchmark's.
        std::freopen("/dev/null", "w", stdout);
        ::execv(argv[0], argv.data());
        ::_exit(127);
      }
      pids_.push_back(pid);
    }
  }
  ~ExternalReaders() {
    for (const pid_t pid : pids_) ::kill(pid, SIGKILL);
    for (const pid_t pid : pids_) ::waitpid(pid, nullptr, 0);
  }
  const std::map<std::string, int>& per_mode() const { return per_mode_; }

 private:
  std::vector<pid_t> pids_;
  std::map<std::string, int> per_mode_;
};

// The outages of the kills of each service (bench pipeline --kill a,a,a,b: several per service).
struct ServiceOutages {
  int kills = 0;
  std::vector<double> outage_ms, first_fresh_ms;  // of the kills it recovered from
  double median_outage_ms() const {
    return outage_ms.empty() ? std::nan("") : thermovis::metrics::percentile(outage_ms, 50);
  }
  double median_first_fresh_ms() const {
    return first_fresh_ms.empty() ? std::nan("")
                                  : thermovis::metrics::percentile(first_fresh_ms, 50);
  }
};

std::map<std::string, ServiceOutages> outages_by_service(
    const std::vector<thermovis::cli::ServiceOutage>& outages) {
  std::map<std::string, ServiceOutages> out;
  for (const auto& o : outages) {
    ServiceOutages& s = out[o.service];
    ++s.kills;
    if (!o.recovered) continue;
    s.outage_ms.push_back(o.outage_ms);
    s.first_fresh_ms.push_back(o.first_fresh_ms);
  }
  return out;
}

// One measurement's headline: the captures answered, latency and misses.
nlohmann::json headline(const thermovis::supervisor::LatencySummary& l) {
  return {{"frames", l.frames},
          {"p50_ms", l.p50_ms},
          {"p99_ms", l.p99_ms},
          {"dropped", l.dropped},
          {"deadline_misses", l.deadline_misses}};
}

// Runs the session (and the display, if any) for `seconds`, or until a stop signal; false when
// stopped early.
bool run_for(thermovis::cli::PipelineSession& session, thermovis::cli::DisplaySession* display,
             double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (thermovis::node::stop_requested()) return false;
    session.step();
    session.step_obstacles();
    if (display != nullptr) display->poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// The machine's own stalls over the measurement (process::HostStallProbe), and the late frames
// and DEADLINE misses that fell in one of at least kStallMs: a frame whose capture-to-output
// interval overlaps it; a miss whose health came within kMissWindowNs after it (the miss is
// counted a DEADLINE period after the last sample and published at the service's next tick).
struct HostStallReport {
  std::string scheduling;
  std::vector<int> cpus;
  thermovis::process::HostStallSummary stalls;
  std::uint64_t over_deadline_in_stalls = 0;  // of LatencySummary::over_deadline
  std::uint64_t deadline_misses = 0, deadline_misses_in_stalls = 0;
  std::map<std::string, std::uint64_t> misses_outside_stalls;  // by "service topic"
};
constexpr double kStallMs = 5.0;
constexpr std::int64_t kMissWindowNs = 100'000'000;

// `r` holds the probe's scheduling and CPUs.
void attribute_to_stalls(HostStallReport& r,
                         const std::vector<thermovis::process::HostStall>& stalls,
                         const thermovis::supervisor::LatencySummary& latency,
                         const std::vector<thermovis::supervisor::LateFrame>& late) {
  r.stalls = thermovis::process::summarize(stalls, r.cpus);
  for (const auto& frame : late)
    r.over_deadline_in_stalls +=
        thermovis::process::during_stall(stalls, frame.capture_ns, frame.output_ns, kStallMs);
  for (const auto& miss : latency.deadline_miss_events) {
    r.deadline_misses += miss.misses;
    if (thermovis::process::during_stall(stalls, miss.time_ns - kMissWindowNs, miss.time_ns,
                                         kStallMs))
      r.deadline_misses_in_stalls += miss.misses;
    else
      r.misses_outside_stalls[miss.endpoint] += miss.misses;
  }
}

nlohmann::json host_stall_json(const HostStallReport& r) {
  nlohmann::json by_cpu = nlohmann::json::object();
  for (const auto& [cpu, n] : r.stalls.over_5ms_by_cpu) by_cpu[std::to_string(cpu)] = n;
  return {{"probe", r.scheduling},
          {"cpus", r.cpus},
          {"over_5ms", r.stalls.over_5ms},
          {"over_10ms", r.stalls.over_10ms},
          {"max_ms", r.stalls.max_ms},
          {"total_ms", r.stalls.total_ms},
          {"over_5ms_by_cpu", by_cpu},
          {"over_deadline_in_stalls", r.over_deadline_in_stalls},
          {"deadline_misses", r.deadline_misses},
          {"deadline_misses_in_stalls", r.deadline_misses_in_stalls},
          {"deadline_misses_outside_stalls_by_endpoint", r.misses_outside_stalls}};
}

std::string host_stall_text(const HostStallReport& r, std::uint64_t over_deadline,
                            double deadline_ms) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << "  host: CPUs stopped " << r.stalls.over_5ms
      << " times for 5 ms or more (" << r.stalls.over_10ms << " for 10 ms or more, longest "
      << r.stalls.max_ms << " ms; a probe at " << r.scheduling << " on " << r.cpus.size()
      << " CPUs); during them: " << r.over_deadline_in_stalls << " of " << over_deadline
      << " frames over " << deadline_ms << " ms, " << r.deadline_misses_in_stalls << " of "
      << r.deadline_misses << " DEADLINE misses\n";
  return out.str();
}

// The page's display latency (DisplaySession::latency) as one line, beside the paper's figure.
std::string display_text(const nlohmann::json& latency, const std::string& browser) {
  std::ostringstream out;
  if (latency.is_null() || latency.value("frames", 0) == 0) {
    out << "  display: no frame shown and measured by " << browser << "\n";
    return out.str();
  }
  const auto p50 = [&](const char* part) { return latency[part]["p50_ms"].get<double>(); };
  out << std::fixed << std::setprecision(1) << "  display (" << browser
      << "): capture to pixels p50 " << p50("capture_to_shown") << " ms, p95 "
      << latency["capture_to_shown"]["p95_ms"].get<double>() << " ms over "
      << latency["frames"].get<int>() << " frames shown (the paper: 22.31 ms); p50 of its parts: "
      << "capture to range " << p50("capture_to_range") << ", range to JPEG "
      << p50("range_to_encoded") << ", JPEG to page " << p50("encoded_to_shown") << " ms\n";
  return out.str();
}

// CPU of each process over the measurement per capture (the camera's 50 Hz slots the
// measurement spanned: what the machine spends per slot, whether the capture was answered or
// dropped), and the floor beside it, measured here after the pipeline stopped on one capture of
// the simulated rig and the geometry's grid.
struct CpuBudget {
  std::uint64_t captures = 0;                    // captures the measurement spanned
  std::uint64_t answered = 0;                    // of which reached the output
  std::map<std::string, double> per_service_ms;  // CPU ms per capture (NaN: unknown)
  double pipeline_ms = std::nan("");             // every service but the bridge (the camera's cost)
  double floor_ms = std::nan("");
  double linear_floor_ms = std::nan("");  // the same with INTER_LINEAR (capture_floor.hpp)
  cv::Size grid;
};

CpuBudget cpu_budget(const thermovis::cli::PipelineSession& session,
                     const std::vector<thermovis::cli::ProcessCpu>& cpu,
                     const std::optional<thermovis::pipeline::PipelineGeometry>& geometry,
                     const thermovis::supervisor::LatencySummary& latency) {
  CpuBudget b;
  b.answered = latency.frames;
  if (latency.frames > 0) b.captures = latency.last_seq - latency.first_seq + 1;
  double pipeline = 0;
  for (const auto& p : cpu) {
    const double ms =
        b.captures > 0 ? 1e3 * p.cpu_s / static_cast<double>(b.captures) : std::nan("");
    b.per_service_ms[p.service] = ms;
    if (p.service != "bridge") pipeline += ms;
  }
  if (b.captures > 0) b.pipeline_ms = pipeline;
  if (geometry) {
    b.grid = geometry->grid_size();
    thermovis::sim::FrameSet frames = session.simulated().allocate();
    session.simulated().render(0, frames);
    const cv::Size infrared = geometry->image_size(thermovis::pipeline::Band::infrared);
    b.floor_ms = thermovis::cli::capture_floor_cpu_ms(frames.images, b.grid, infrared);
    b.linear_floor_ms =
        thermovis::cli::capture_floor_cpu_ms(frames.images, b.grid, infrared, 5, cv::INTER_LINEAR);
  }
  return b;
}

int run_bench(Options& opt) {
  thermovis::node::install_stop_handlers();
  if (opt.view || !opt.display.browser.empty()) thermovis::cli::with_display(opt.session);
  thermovis::cli::PipelineSession session(opt.session);
  session.start();
  if (!opt.json) {
    std::cout << "warming up for " << opt.warmup_s << " s, then measuring for " << opt.seconds
              << " s (DDS domain " << opt.session.domain << ")" << std::endl;
  }
  std::unique_ptr<thermovis::cli::DisplaySession> display;
  if (opt.view || !opt.display.browser.empty()) {
    display = std::make_unique<thermovis::cli::DisplaySession>(opt.session, opt.display);
  }
  std::optional<thermovis::process::HostStallProbe> probe;
  if (opt.host_probe) probe.emplace();
  const auto reset_statistics = [&] {
    session.reset_statistics();
    if (display) display->reset_statistics();
    if (probe) probe->reset();
  };
  run_for(session, display.get(), opt.warmup_s);
  // The simulated bridge renders live what it has not prerendered yet (20 ms a capture on the
  // street scene, over a core): the measurement waits for its steady state (a minute at most:
  // a bridge that died while preparing leaves its last health behind).
  for (int waited_s = 0; waited_s < 60; ++waited_s) {
    const std::string preparing = session.source_preparing();
    if (preparing.empty()) break;
    if (!opt.json) std::cout << "waiting for the bridge: " << preparing << std::endl;
    if (!run_for(session, display.get(), 1.0)) break;
  }
  reset_statistics();
  // With external readers: the measurement without them first, then theirs (the rest of this
  // function) after they have matched.
  std::optional<thermovis::supervisor::LatencySummary> without_readers;
  std::unique_ptr<ExternalReaders> readers;
  if (opt.external_readers > 0) {
    run_for(session, display.get(), opt.seconds);
    without_readers = session.latency();
    readers = std::make_unique<ExternalReaders>(opt.external_readers, opt.session.domain,
                                                opt.external_hold_ms, 3.0 + opt.seconds / 3);
    run_for(session, display.get(), 3.0);
    reset_statistics();
  }
  // Kills spread evenly over the measured time, each with time to recover before the next.
  const double slice = opt.seconds / static_cast<double>(opt.kill.size() + 1);
  bool running = true;
  for (const std::string& service : opt.kill) {
    running = running && run_for(session, display.get(), slice);
    if (running) session.kill_service(service);
  }
  if (running) run_for(session, display.get(), slice);
  auto cpu = session.cpu();  // before stopping: the processes must still be there
  std::optional<HostStallReport> host;
  std::vector<thermovis::process::HostStall> stalls;
  if (probe) {
    host.emplace();
    host->scheduling = probe->scheduling();
    host->cpus = probe->cpus();
    stalls = probe->stalls();
    probe.reset();  // its threads stop with the measurement
  }
  nlohmann::json display_latency;
  std::vector<thermovis::cli::ProcessCpu> display_cpu;
  if (display) {
    display_cpu = display->cpu();
    if (!opt.display.browser.empty()) display_latency = display->latency();
    display->stop();
  }
  const auto geometry = session.geometry();
  session.stop();
  const auto latency = session.latency();
  const CpuBudget budget = cpu_budget(session, cpu, geometry, latency);
  if (host) attribute_to_stalls(*host, stalls, latency, session.late_frames());
  // Not part of the budget (the pipeline's), but listed beside its processes.
  cpu.insert(cpu.end(), display_cpu.begin(), display_cpu.end());
  const auto errors = session.errors();
  const auto obstacles = session.obstacle_errors();
  if (opt.json) {
    auto j = thermovis::cli::summary_json(latency, errors, &obstacles);
    j["seconds"] = opt.seconds;
    j["prerender"] = opt.session.prerender;
    j["grid_scale"] = opt.session.grid_scale;
    j["fused_rate_hz"] = std::isnan(opt.session.fused_rate_hz) ? 0.0 : opt.session.fused_rate_hz;
    nlohmann::json processes = nlohmann::json::object();
    for (const auto& p : cpu) {
      processes[p.service] = {
          {"cpu_percent",
           std::isfinite(p.cpu_percent) ? nlohmann::json(p.cpu_percent) : nlohmann::json()},
          {"rss_mb", p.rss_mb},
          {"scheduling", p.scheduling}};
    }
    j["processes"] = processes;
    const auto number = [](double v) {
      return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
    };
    nlohmann::json per_capture = nlohmann::json::object();
    for (const auto& [service, ms] : budget.per_service_ms) per_capture[service] = number(ms);
    j["cpu_ms_per_capture"] = per_capture;
    j["pipeline_cpu_ms_per_capture"] = number(budget.pipeline_ms);
    j["floor_cpu_ms"] = number(budget.floor_ms);
    j["pipeline_over_floor"] = number(budget.pipeline_ms / budget.floor_ms);
    j["linear_floor_cpu_ms"] = number(budget.linear_floor_ms);
    if (host) j["host_stalls"] = host_stall_json(*host);
    nlohmann::json outages = nlohmann::json::object();
    for (const auto& [service, o] : outages_by_service(session.outages())) {
      outages[service] = {{"kills", o.kills},
                          {"recovered", o.outage_ms.size()},
                          {"outage_ms", o.outage_ms},
                          {"first_fresh_ms", o.first_fresh_ms},
                          {"median_outage_ms", number(o.median_outage_ms())},
                          {"median_first_fresh_ms", number(o.median_first_fresh_ms())}};
    }
    if (!opt.kill.empty()) j["outages"] = outages;
    if (!opt.display.browser.empty()) j["display"] = display_latency;
    if (readers) {
      j["external_readers"] = readers->per_mode();
      j["without_external_readers"] = headline(*without_readers);
    }
    std::cout << j.dump() << std::endl;
  } else {
    if (readers) {
      std::cout << "without external readers: frames " << without_readers->frames << ", p50 "
                << std::fixed << std::setprecision(2) << without_readers->p50_ms << " ms, p99 "
                << without_readers->p99_ms << " ms; dropped " << without_readers->dropped
                << "; DEADLINE QoS misses " << without_readers->deadline_misses << "\nwith "
                << opt.external_readers << " external readers of every frame topic (";
      for (const auto& [mode, n] : readers->per_mode()) std::cout << n << " " << mode << " ";
      std::cout << "):\n";
    }
    std::cout << thermovis::supervisor::summary_text(latency, session.deadline_ms());
    if (host) std::cout << host_stall_text(*host, latency.over_deadline, session.deadline_ms());
    for (const auto& p : cpu) {
      std::cout << "  process " << std::setw(13) << std::left << p.service << std::right << " cpu "
                << std::fixed << std::setprecision(1) << std::setw(6) << p.cpu_percent << " %  rss "
                << std::setw(7) << p.rss_mb << " MB  " << p.scheduling << "\n";
    }
    std::cout << "  CPU per capture (" << budget.captures << " captures, " << budget.answered
              << " answered):";
    for (const auto& [service, ms] : budget.per_service_ms) {
      std::cout << " " << service << " " << std::setprecision(1) << ms << " ms";
    }
    std::cout << "\n  pipeline without the bridge (the camera's cost) " << budget.pipeline_ms
              << " ms; floor " << std::setprecision(2) << budget.floor_ms
              << " ms (one copy of every image of a capture + cv::resize INTER_AREA of each to "
              << "its band's grid, visible " << budget.grid.width << "x" << budget.grid.height
              << "): " << std::setprecision(1) << budget.pipeline_ms / budget.floor_ms
              << " x floor; with INTER_LINEAR " << std::setprecision(2) << budget.linear_floor_ms
              << " ms: " << std::setprecision(1) << budget.pipeline_ms / budget.linear_floor_ms
              << " x\n";
    for (const auto& [service, o] : outages_by_service(session.outages())) {
      if (o.kills < 2) continue;
      std::cout << "  " << service << ": killed " << o.kills << " times, recovered "
                << o.outage_ms.size() << "; median outage " << std::setprecision(0)
                << o.median_outage_ms() << " ms, median first result of a new capture "
                << o.median_first_fresh_ms() << " ms after the kill\n";
    }
    for (const auto& o : session.outages()) {
      if (o.recovered) {
        std::cout << "  killed " << std::setw(12) << std::left << o.service << std::right
                  << (o.service == "obstacles" ? " obstacles" : " ranges") << " stopped for "
                  << std::fixed << std::setprecision(0) << o.outage_ms
                  << " ms (first result of a new capture " << o.first_fresh_ms
                  << " ms after the kill)\n";
      } else {
        std::cout << "  killed " << o.service << ": no result of a new capture before the end\n";
      }
    }
    if (!opt.display.browser.empty())
      std::cout << display_text(display_latency, opt.display.browser);
    std::cout << thermovis::cli::errors_text(errors)
              << thermovis::cli::obstacle_errors_text(obstacles);
  }
  return latency.frames > 0 ? 0 : 2;
}

THERMOVIS_COMMAND("bench pipeline",
                  "all services at 50 Hz: latency p50/p99/max per stage, CPU, drops, misses",
                  [](CLI::App& app) -> thermovis::cli::Runner {
                    auto opt = std::make_shared<Options>();
                    // The simulated bridge copies pre-rendered captures: the benchmark measures
                    // the pipeline, not the simulator (bench_sim measures that).
                    opt->session.prerender = 100;
                    thermovis::cli::add_session_options(app, opt->session);
                    app.add_option("--seconds", opt->seconds, "measured time")
                        ->capture_default_str()
                        ->check(CLI::PositiveNumber);
                    app.add_option("--warmup", opt->warmup_s, "time before measuring, s")
                        ->capture_default_str()
                        ->check(CLI::NonNegativeNumber);
                    app.add_flag("--json", opt->json, "one JSON object");
                    app.add_option("--kill", opt->kill,
                                   "SERVICE[,SERVICE...]: kill each (SIGKILL) once, evenly "
                                   "spread over the measured time (a service named N times: N "
                                   "kills); reports the outage of each (obstacles: of "
                                   "thermovis/obstacles), and the median per service")
                        ->delimiter(',')
                        ->check(CLI::IsMember(
                            {"bridge", "rectify-fuse", "detect", "match", "range", "obstacles"}));
                    app.add_option("--external-readers", opt->external_readers,
                                   "measure again with N other DDS applications reading every "
                                   "frame topic (idle, slow, crashing in turn)")
                        ->capture_default_str()
                        ->check(CLI::Range(0, 64));
                    app.add_option("--external-hold-ms", opt->external_hold_ms,
                                   "how long a slow external reader holds each frame")
                        ->capture_default_str()
                        ->check(CLI::Range(0, 10000));
                    app.add_flag("!--no-host-probe", opt->host_probe,
                                 "without the probe of the machine's own stalls (a thread per "
                                 "CPU at fifo 50 waking every ms)");
                    app.add_flag("--view", opt->view,
                                 "also run the live display (thermovis-view), as `run --view`");
                    app.add_option("--view-port", opt->display.port, "HTTP port of the display")
                        ->capture_default_str()
                        ->check(CLI::Range(1, 65535));
                    app.add_option("--browser", opt->display.browser,
                                   "with the display: this Chromium-like browser, headless, on "
                                   "its page; reports capture-to-pixels latency (e.g. "
                                   "/usr/bin/chromium)");
                    return [opt] { return run_bench(*opt); };
                  });

}  // namespace
