#pragma once
// The whole pipeline on the simulated rig, as `thermovis run` and `thermovis bench pipeline`
// use it: the supervisor (in this process) starts the services of the manifest on a DDS domain,
// and every range result is checked against the simulated scene's ground truth.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "supervisor.hpp"
#include "thermovis/obstacles.h"
#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "truth_match.hpp"

namespace thermovis::node {
class GeometrySubscriber;
}
namespace thermovis::transport {
template <class T>
class Reader;
}

namespace thermovis::cli {

struct SessionOptions {
  std::string scene;     // empty: the shipped paper scene
  std::string rig;       // empty: the default rig
  std::string manifest;  // empty: the shipped pipeline.yaml
  std::string log_dir = "/tmp/thermovis-logs";
  int domain = 0;
  std::string profile;  // empty: the shared-memory host profile
  double latency_deadline_ms = 20.0;
  int prerender = 0;        // the bridge's pre-rendered captures (0: renders live)
  double grid_scale = 0.5;  // rectify-fuse --grid-scale (the manifest's ${grid_scale})
  // rectify-fuse --fused-rate-hz (the manifest's ${fused_rate_hz}); NaN: not given, which is
  // every capture (0), or kDisplayFusedRateHz once with_display() is called.
  double fused_rate_hz = std::numeric_limits<double>::quiet_NaN();
};

// thermovis-view composes at most 15 pictures a second (its --max-fps): the fused frames the
// display needs. 15 Hz fuses every third capture at 50 Hz (16.7 a second).
constexpr double kDisplayFusedRateHz = 15.0;
// A session with the live display: the fused rate, unless given, is the display's.
void with_display(SessionOptions& options);

// Adds --scene, --rig, --manifest, --domain (default $THERMOVIS_DOMAIN), --profile, --log-dir,
// --latency-deadline-ms, --prerender, --grid-scale and --fused-rate-hz.
void add_session_options(CLI::App& app, SessionOptions& options);

// One range of the pipeline with the simulated target it belongs to, if any
// (truth_on_line_of_sight, truth_match.hpp).
struct CheckedRange {
  std::uint64_t seq = 0;
  TargetRange range;
  std::optional<TruthSummary> truth;
  double error_m = 0.0;     // distance - truth distance (when truth)
  double latency_ms = 0.0;  // capture to range, from the frame's stamps
};

// One obstacle of thermovis/obstacles with the simulated target it is, if any: of the targets
// whose silhouette's box on the grid overlaps its box (a fifth of the smaller), the one at its
// distance within 15 % + 0.5 m (as `thermovis bench obstacles` counts them); the truth distance
// is what the obstacle's distance measures, horizontal, to the target's nearest surface point.
// An entry that is a ranged target has its range's truth (truth_on_line_of_sight), at the
// target's centre. Walls, hedges and the like are no simulated targets: their obstacles have no
// truth.
struct CheckedObstacle {
  std::uint64_t seq = 0;
  Obstacle obstacle;
  std::optional<TruthSummary> truth;
  double truth_distance_m = 0.0;  // when truth
  double error_m = 0.0;           // distance - truth distance (when truth)
  double latency_ms = 0.0;        // capture to the obstacle array, from its stamps
};

struct ObstacleErrorSummary {
  std::uint64_t frames = 0;     // obstacle arrays received
  std::uint64_t obstacles = 0;  // obstacles in them
  std::uint64_t targets = 0;    // of which ranged targets (persons)
  std::uint64_t matched = 0;    // of which belong to a simulated target
  double median_abs_error_m = 0.0, median_abs_relative_error = 0.0;
  double latency_p50_ms = 0.0, latency_p99_ms = 0.0;  // capture to the obstacle array
  // Per simulated target: the truth distance, the obstacles matched to it, their median error.
  struct PerTarget {
    std::string id;
    double truth_m = 0.0;
    std::uint64_t found = 0;
    double median_error_m = 0.0;
  };
  std::vector<PerTarget> targets_found;
};

struct RangeErrorSummary {
  std::uint64_t frames = 0;   // range results received
  std::uint64_t ranges = 0;   // targets ranged
  std::uint64_t matched = 0;  // of which belong to a simulated target
  double mean_abs_error_m = 0.0, p95_abs_error_m = 0.0, max_abs_error_m = 0.0;
  double mean_abs_relative_error = 0.0;  // |error| / truth distance
  // Per target id: the truth distance and the mean error of its ranges.
  struct PerTarget {
    std::string id;
    double truth_m = 0.0;
    std::uint64_t ranges = 0;
    double mean_error_m = 0.0, mean_sigma_m = 0.0;
  };
  std::vector<PerTarget> targets;
};

struct ProcessCpu {
  std::string service;
  double cpu_percent = 0.0;  // user + system time over wall time since the last mark, % of a core
  double cpu_s = 0.0;        // user + system time since the last mark, s (NaN: unknown)
  double rss_mb = 0.0;       // resident memory now
  std::string scheduling;    // its policy now: "normal", "idle", "fifo 10" ("": gone)
};

// CPU of processes since a mark, by pid: a process started since (restarted) has no mark and
// its figures are unknown (NaN). `whole_group`: each service's whole process group (a service
// and the helpers it starts, such as a browser's; process::ProcessGroup starts each service in
// a group of its own), with the time of the children they have waited for.
class CpuMarks {
 public:
  explicit CpuMarks(bool whole_group = false) : whole_group_(whole_group) {}
  void mark(const std::vector<process::ServiceStatus>& services);
  std::vector<ProcessCpu> since(const std::vector<process::ServiceStatus>& services) const;

 private:
  struct Mark {
    double cpu_s = 0.0;
    double wall_s = 0.0;
  };
  bool usage(int pid, double& cpu_s, double& rss_bytes) const;
  bool whole_group_;
  std::map<int, Mark> marks_;  // by pid
};

// A service killed on purpose (SIGKILL) during a session, and how long the ranges stopped (the
// obstacle service: the obstacles).
struct ServiceOutage {
  std::string service;
  bool recovered = false;       // a range of a frame captured after the kill arrived
  double first_fresh_ms = 0.0;  // kill to that range
  double outage_ms = 0.0;       // the last range received before the kill to that range
};

class PipelineSession {
 public:
  explicit PipelineSession(const SessionOptions& options);
  ~PipelineSession();

  void start();
  // Polls the services and topics; the ranges received since the last call, checked.
  std::vector<CheckedRange> step();
  // The obstacles received since the last call (thermovis/obstacles), checked.
  std::vector<CheckedObstacle> step_obstacles();
  ObstacleErrorSummary obstacle_errors() const;
  // Starts the statistics again (after a warm-up): latency, ranging errors, CPU.
  void reset_statistics();
  void stop();
  // SIGKILL to a running service of the manifest ("detect"); the supervisor restarts it and
  // step() measures the outage. Throws std::invalid_argument for a service not running.
  void kill_service(const std::string& name);
  const std::vector<ServiceOutage>& outages() const { return outages_; }

  supervisor::LatencySummary latency() const { return supervisor_->summary(); }
  // What the bridge's source still prepares (its health message, node::kSourcePreparing), e.g.
  // "37 of 100 captures prerendered"; empty once it runs as it will, or before it reported.
  std::string source_preparing() const;
  RangeErrorSummary errors() const;
  std::vector<ProcessCpu> cpu() const;
  const std::vector<supervisor::LateFrame>& late_frames() const {
    return supervisor_->late_frames();
  }
  std::vector<process::ServiceStatus> services() const { return supervisor_->services(); }
  double deadline_ms() const { return options_.latency_deadline_ms; }
  // The grid geometry rectify-fuse publishes (thermovis/geometry), once it has arrived.
  std::optional<pipeline::PipelineGeometry> geometry();
  // The simulated rig the bridge renders (same rig and scene).
  const sim::SimulatedRig& simulated() const { return *sim_; }

 private:
  // The simulated truth of the capture `seq`. Computing it projects every target's silhouette
  // into the four cameras (their boxes): milliseconds a frame, which a session checking every
  // range of a 50 Hz pipeline cannot spend per range. It is computed once per frame; with
  // pre-rendered captures (cycled), once per pre-rendered frame, and kept.
  const std::vector<sim::TargetTruth>& truth_at(std::uint64_t seq);
  // A range array (or, `obstacles`, an obstacle array) of the capture at capture_ns arrived:
  // the outages of the services that give it end.
  void note_arrival(bool obstacles, std::int64_t capture_ns,
                    std::chrono::steady_clock::time_point arrival);
  // Per target of truth_at(seq): its silhouette's box on the grid (left visible image) and the
  // horizontal distance (along `down`'s plane) of its nearest surface point, kept as truth_at.
  const std::vector<std::pair<cv::Rect, double>>& grid_truth_at(
      std::uint64_t seq, const pipeline::PipelineGeometry& geometry, const Eigen::Vector3d& down);

  SessionOptions options_;
  std::unique_ptr<sim::SimulatedRig> sim_;                                // for the truth only
  std::map<std::int64_t, std::vector<sim::TargetTruth>> truth_by_frame_;  // see truth_at
  std::map<std::int64_t, std::vector<std::pair<cv::Rect, double>>> grid_truth_by_frame_;
  std::unique_ptr<transport::Participant> participant_;
  std::unique_ptr<supervisor::Supervisor> supervisor_;
  std::unique_ptr<node::GeometrySubscriber> geometry_;
  std::unique_ptr<transport::Reader<ObstacleArray>> obstacles_in_;
  std::uint64_t frames_ = 0, obstacle_frames_ = 0;
  std::vector<CheckedObstacle> checked_obstacles_;
  std::vector<double> obstacle_latency_ms_;  // per obstacle array
  std::vector<CheckedRange> checked_;
  CpuMarks cpu_marks_;
  std::vector<ServiceOutage> outages_;
  std::vector<std::int64_t> killed_ns_;  // capture clock at each kill (transport::now_ns)
  std::vector<std::chrono::steady_clock::time_point> killed_at_, last_before_kill_;
  std::chrono::steady_clock::time_point last_arrival_{}, last_obstacle_arrival_{};
};

// The per-range line `thermovis run` prints, and its JSON form.
std::string range_line(const CheckedRange& checked);
std::string range_json(const CheckedRange& checked);
std::string errors_text(const RangeErrorSummary& errors);
// The per-obstacle line (entries that are not ranged targets: those have their range line) and
// its JSON form ("kind": "obstacle"; every entry).
std::string obstacle_line(const CheckedObstacle& checked);
std::string obstacle_json(const CheckedObstacle& checked);
std::string obstacle_errors_text(const ObstacleErrorSummary& errors);
// The supervisor's latency summary (supervisor::summary_json) with the ranging errors added:
// ranges, ranges_on_target, mean_abs_error_m, p95_abs_error_m, mean_abs_relative_error.
// With `obstacles`, also obstacle_frames, obstacles, obstacles_on_target,
// obstacle_median_abs_error_m, obstacle_latency_p50_ms, obstacle_latency_p99_ms.
nlohmann::json summary_json(const supervisor::LatencySummary& latency,
                            const RangeErrorSummary& errors,
                            const ObstacleErrorSummary* obstacles = nullptr);

}  // namespace thermovis::cli
