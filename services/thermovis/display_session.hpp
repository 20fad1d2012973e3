#pragma once
// The live display beside a pipeline session, as `thermovis run --view` and
// `thermovis bench pipeline --view` start it: thermovis-view on the session's DDS domain and,
// for a measurement, a headless browser showing its page. Each runs in a process group of its
// own (the viewer restarted if it exits), so the pipeline's manifest is the same with or without
// a display. The viewer reads frames, so it is stopped before the pipeline (a reader must be
// gone before the writers of the frames it holds).
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pipeline_session.hpp"

namespace thermovis::process {
class ProcessGroup;
}

namespace thermovis::cli {

struct DisplayOptions {
  int port = 8090;
  // A Chromium-like browser run headless on the page (it streams the fused view and reports
  // what it shows, /display-latency); empty: no browser.
  std::string browser;
};

class DisplaySession {
 public:
  // Starts thermovis-view; with a browser, waits up to 20 s for the page to answer, then starts
  // the browser on it. Throws std::runtime_error when the page never answers.
  DisplaySession(const SessionOptions& session, const DisplayOptions& options);
  ~DisplaySession();
  DisplaySession(const DisplaySession&) = delete;
  DisplaySession& operator=(const DisplaySession&) = delete;

  std::string url() const;
  void poll();  // restarts the viewer if it exited
  void stop();
  // Marks the start of the CPU figures of cpu() (after a warm-up).
  void reset_statistics();
  // The viewer and the browser: CPU since the last mark (every process of each one's group: a
  // browser runs several) and resident memory.
  std::vector<ProcessCpu> cpu() const;
  // What the page measured (the viewer's /display-latency.json: capture_to_shown,
  // capture_to_range, range_to_encoded, encoded_to_shown, each p50_ms, p95_ms, max_ms, and
  // frames); null when the viewer does not answer.
  nlohmann::json latency() const;

 private:
  DisplayOptions options_;
  std::unique_ptr<process::ProcessGroup> viewer_, browser_;
  CpuMarks marks_{true};  // every process of each one's group: a browser runs several
};

}  // namespace thermovis::cli
