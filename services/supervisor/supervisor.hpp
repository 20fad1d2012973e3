#pragma once
// The supervisor: runs the services of a manifest (process::ProcessGroup), watches their health
// over DDS (a service whose health stops arriving is restarted as hung), and measures every
// frame's capture-to-output latency from the stamps the frames carry (thermovis/timing), with
// the stage that used the time, against the latency deadline.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "thermovis/health.h"
#include "thermovis/perception.h"
#include "thermovis/process/process_group.hpp"
#include "thermovis/transport/reader.hpp"

namespace thermovis::supervisor {

struct SupervisorConfig {
  std::map<std::string, std::string> vars;  // manifest substitutions (bin, domain, ...)
  std::filesystem::path log_dir;            // service logs
  double latency_deadline_ms = 20.0;        // capture-to-output budget of one frame
  double hung_after_s = 5.0;                // no health for this long (once seen): restart
  // A new process that never reported is given this long: the simulated bridge renders its
  // --prerender captures before its first health (over 20 s for 100 on a loaded machine).
  double startup_grace_s = 60.0;
};

struct StageLatency {
  std::string stage;
  double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;  // the stage's own time per frame
  // When its output was ready, after the capture: where a frame's time goes along the chain
  // (a stage's p50 above is its work and its waits; the gap to the one before is transport).
  double done_p50_ms = 0.0, done_p99_ms = 0.0;
};

// DEADLINE misses counted by one service on one topic, at the time of the health that first
// carried them (a service publishes its health when it sees a miss counted: node/health.hpp).
struct DeadlineMissEvent {
  std::int64_t time_ns = 0;  // the health's time_ns (CLOCK_REALTIME)
  std::string endpoint;      // "service topic"
  std::uint64_t misses = 0;
};

struct LatencySummary {
  std::uint64_t frames = 0;  // frames that reached the output
  double p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
  std::uint64_t over_deadline = 0;    // frames whose capture-to-output latency exceeded it
  std::uint64_t deadline_misses = 0;  // DEADLINE QoS misses over every service's topics
  // The same per "service topic" (a late sample counts at its writer and at each reader).
  std::map<std::string, std::uint64_t> deadline_misses_by_endpoint;
  // The same as they were reported (the first 10000 since the last reset).
  std::vector<DeadlineMissEvent> deadline_miss_events;
  std::uint64_t bad_inputs = 0;  // errors reported in health, and bad_timing
  std::uint64_t bad_timing = 0;  // thermovis/timing samples rejected (node::check_timing)
  std::uint64_t restarts = 0;
  std::uint64_t first_seq = 0, last_seq = 0;  // output frames seen
  std::uint64_t dropped =
      0;  // captures between first_seq and last_seq that never reached the output
  std::vector<StageLatency> stages;
  struct ServiceRestarts {
    std::string service;
    std::uint64_t restarts = 0;  // since the last reset
    std::string last_error;      // why it last stopped, in words
  };
  std::vector<ServiceRestarts> restarted;  // the services restarted since the last reset
};

// One frame that went over the latency deadline, with the stage that used the most time.
struct LateFrame {
  std::uint64_t seq = 0;
  std::int64_t capture_ns = 0;  // its capture and output, on the stamps' clock
  std::int64_t output_ns = 0;
  double latency_ms = 0.0;
  std::string slowest_stage;
  double slowest_stage_ms = 0.0;
};

const char* stage_name(Stage stage);

// The health key a manifest service reports under: "bridge" -> "thermovis-bridge".
std::string health_key(const std::string& service);

class Supervisor {
 public:
  Supervisor(transport::Participant& participant, process::Manifest manifest,
             SupervisorConfig config);
  ~Supervisor();

  void start();
  // Polls the processes and the topics once; returns the range results received since the last
  // call (copies).
  std::vector<RangeArray> step();
  void stop();

  // Forgets the latencies, late frames and counts so far (e.g. after a warm-up): summary()
  // then covers only what follows. Cumulative counters of health are taken as the new zero.
  void reset_statistics();

  LatencySummary summary() const;
  std::vector<process::ServiceStatus> services() const { return group_.status(); }
  const std::map<std::string, Health>& health() const { return health_; }
  const std::vector<LateFrame>& late_frames() const { return late_; }
  // Data-sharing segments of dead processes removed from /dev/shm at start().
  std::size_t stale_segments_removed() const { return stale_segments_removed_; }

 private:
  void take_timing();
  void take_health();
  // The misses `now` counts beyond `before` (the same service's previous health, or none).
  void record_misses(const Health* before, const Health& now);
  void check_hung();

  SupervisorConfig config_;
  process::ProcessGroup group_;
  transport::Reader<FrameTiming> timing_in_;
  transport::Reader<Health> health_in_;
  transport::Reader<RangeArray> ranges_in_;
  std::map<std::string, Health> health_;        // by service health key
  std::vector<DeadlineMissEvent> miss_events_;  // since the last reset
  std::map<std::string, std::chrono::steady_clock::time_point> last_health_;
  struct Instance {
    int pid = -1;
    std::chrono::steady_clock::time_point started{};
  };
  std::map<std::string, Instance> instances_;  // by manifest name: the process being watched
  std::vector<double> latencies_ms_;
  struct StageSamples {
    std::vector<double> own_ms;   // the stamps' durations
    std::vector<double> done_ms;  // their end_ns after the capture
  };
  std::map<Stage, StageSamples> stage_ms_;
  std::vector<LateFrame> late_;
  std::uint64_t first_seq_ = 0, last_seq_ = 0;
  std::size_t stale_segments_removed_ = 0;
  std::uint64_t bad_timing_ = 0;  // timing samples rejected, kept out of the latencies
  // Cumulative counts at the last reset_statistics().
  std::uint64_t base_bad_inputs_ = 0, base_deadline_misses_ = 0, base_bad_timing_ = 0;
  std::map<std::string, std::uint64_t> base_deadline_misses_by_endpoint_;
  std::map<std::string, int> base_restarts_;  // by manifest name
};

// The substitutions of the shipped manifest: bin (the folder of the running executable, where
// the services are), domain, profile, scene (the shipped paper scene when empty; made absolute),
// prerender (0: the bridge renders live).
std::map<std::string, std::string> default_vars(int domain, const std::string& profile,
                                                const std::string& scene);

// The summary as JSON (frames, p50_ms, p99_ms, max_ms, over_deadline, deadline_misses,
// bad_inputs, restarts, restarted: {service: {restarts, last_error}}, stages) and as the lines a
// person reads.
std::string summary_json(const LatencySummary& summary);
std::string summary_text(const LatencySummary& summary, double deadline_ms);

}  // namespace thermovis::supervisor
