#include "pipeline_session.hpp"

#include "truth_match.hpp"

#include <sched.h>
#include <unistd.h>

#include <csignal>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "thermovis/metrics/percentile.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/obstacle/ground.hpp"
#include "thermovis/process/manifest_io.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::cli {
namespace {

// The manifest's name of the obstacle service: its outages are of thermovis/obstacles.
constexpr const char* kObstacleService = "obstacles";
// An obstacle belongs to a simulated target on its line of sight at its distance within this.
constexpr double kObstacleTruthToleranceM = 0.5;
constexpr double kObstacleTruthToleranceShare = 0.15;

double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The fields of /proc/<pid>/stat after the command name: field n of stat(5) is f[n - 3].
bool read_stat(const std::string& pid, std::vector<std::string>& f) {
  std::ifstream in("/proc/" + pid + "/stat");
  std::string text;
  if (!in || !std::getline(in, text)) return false;
  const auto close = text.rfind(')');  // the command name may hold spaces and parentheses
  if (close == std::string::npos) return false;
  std::istringstream fields(text.substr(close + 2));
  f.clear();
  for (std::string item; fields >> item;) f.push_back(item);
  return f.size() >= 22;
}

const double kTicks = static_cast<double>(sysconf(_SC_CLK_TCK));
const double kPageBytes = static_cast<double>(sysconf(_SC_PAGESIZE));

// User + system CPU seconds and resident bytes of a process; false when it is gone.
bool read_process_usage(int pid, double& cpu_s, double& rss_bytes) {
  std::vector<std::string> f;
  if (!read_stat(std::to_string(pid), f)) return false;
  cpu_s = (std::stod(f[14 - 3]) + std::stod(f[15 - 3])) / kTicks;
  rss_bytes = std::stod(f[24 - 3]) * kPageBytes;
  return true;
}

// User + system CPU seconds (with the children it waited for) and resident bytes of every live
// process of process group `pgid`; false when the group has no process.
bool read_group_usage(int pgid, double& cpu_s, double& rss_bytes) {
  cpu_s = rss_bytes = 0;
  bool any = false;
  std::error_code error;
  std::vector<std::string> f;
  for (auto it = std::filesystem::directory_iterator("/proc", error);
       !error && it != std::filesystem::directory_iterator(); it.increment(error)) {
    const std::string pid = it->path().filename().string();
    if (pid.find_first_not_of("0123456789") != std::string::npos) continue;
    if (!read_stat(pid, f) || std::stoll(f[5 - 3]) != pgid) continue;
    // Its own time and that of its children it has waited for (a browser's exited helpers).
    cpu_s += (std::stod(f[14 - 3]) + std::stod(f[15 - 3]) + std::stod(f[16 - 3]) +
              std::stod(f[17 - 3])) /
             kTicks;
    rss_bytes += std::stod(f[24 - 3]) * kPageBytes;
    any = true;
  }
  return any;
}

// The scheduling policy of a process as the manifest names it: "fifo N", "idle", "normal";
// "" when it is gone.
std::string read_scheduling(int pid) {
  std::vector<std::string> f;
  if (pid <= 0 || !read_stat(std::to_string(pid), f) || f.size() < 41 - 2) return "";
  const int policy = std::stoi(f[41 - 3]);
  if (policy == SCHED_FIFO) return "fifo " + f[40 - 3];
  if (policy == SCHED_RR) return "rr " + f[40 - 3];
  if (policy == SCHED_IDLE) return "idle";
  return "normal";
}

std::string fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

}  // namespace

void add_session_options(CLI::App& app, SessionOptions& s) {
  if (const char* env = std::getenv("THERMOVIS_DOMAIN"); env != nullptr && *env != '\0')
    s.domain = std::atoi(env);
  app.add_option("--scene", s.scene, "simulated scene YAML (default deploy/scenes/paper.yaml)");
  app.add_option("--rig", s.rig, "rig YAML (default deploy/rigs/paper.yaml)");
  app.add_option("--manifest", s.manifest, "pipeline manifest (default deploy/pipeline.yaml)");
  app.add_option("--domain", s.domain,
                 "DDS domain of the pipeline (default $THERMOVIS_DOMAIN or 0)")
      ->check(CLI::Range(0, 232));
  app.add_option("--profile", s.profile, "DDS profile (default: shared memory on this host)");
  app.add_option("--log-dir", s.log_dir, "folder of the services' logs")->capture_default_str();
  app.add_option("--latency-deadline-ms", s.latency_deadline_ms, "capture-to-range budget")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--prerender", s.prerender,
                 "captures the bridge renders at start and then cycles (0: renders live)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--grid-scale", s.grid_scale,
                 "rectified grid resolution relative to the visible camera's (1.0: its full grid)")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 1.0));
  app.add_option("--fused-rate-hz", s.fused_rate_hz,
                 "thermovis/fused at most this many captures a second (0: every capture; "
                 "default 0, or 15 with --view: what the display composes)")
      ->check(CLI::NonNegativeNumber);
}

void with_display(SessionOptions& options) {
  if (std::isnan(options.fused_rate_hz)) options.fused_rate_hz = kDisplayFusedRateHz;
}

PipelineSession::PipelineSession(const SessionOptions& options) : options_(options) {
  const auto rig = runtime::load_rig(options.rig.empty() ? runtime::default_rig_path()
                                                         : std::filesystem::path(options.rig));
  supervisor::SupervisorConfig config;
  const std::string profile = options.profile.empty() ? transport::kHostProfile : options.profile;
  config.vars = supervisor::default_vars(options.domain, profile, options.scene);
  config.vars["prerender"] = std::to_string(options.prerender);
  std::ostringstream scale;
  scale << options.grid_scale;
  config.vars["grid_scale"] = scale.str();
  std::ostringstream rate;
  rate << (std::isnan(options.fused_rate_hz) ? 0.0 : options.fused_rate_hz);
  config.vars["fused_rate_hz"] = rate.str();
  // The services find the rig through $THERMOVIS_RIG (runtime::default_rig_path).
  if (!options.rig.empty())
    setenv("THERMOVIS_RIG", std::filesystem::absolute(options.rig).c_str(), 1);
  config.log_dir = options.log_dir;
  config.latency_deadline_ms = options.latency_deadline_ms;
  // The simulated rig answers where each target is at each frame (the seed only moves noise).
  sim_ = std::make_unique<sim::SimulatedRig>(rig, runtime::load_scene(config.vars.at("scene")), 1,
                                             sim::RenderOptions{false, false});
  node::CommonOptions common;
  common.service = "thermovis-run";
  common.domain = options.domain;
  common.profile = profile;
  participant_ = node::make_participant(common);
  geometry_ = std::make_unique<node::GeometrySubscriber>(*participant_);
  obstacles_in_ = std::make_unique<transport::Reader<ObstacleArray>>(
      *participant_, transport::topics::kObstacles, transport::event_topic_qos(64));
  const auto manifest =
      process::load_manifest(options.manifest.empty() ? runtime::shipped_file("pipeline.yaml")
                                                      : std::filesystem::path(options.manifest));
  supervisor_ = std::make_unique<supervisor::Supervisor>(*participant_, manifest, config);
}

PipelineSession::~PipelineSession() { stop(); }

void PipelineSession::start() { supervisor_->start(); }

std::string PipelineSession::source_preparing() const {
  const auto& health = supervisor_->health();
  const auto bridge = health.find(supervisor::health_key("bridge"));
  if (bridge == health.end()) return {};
  const std::string message = bridge->second.message().to_string();
  if (message.rfind(node::kSourcePreparing, 0) != 0) return {};
  return message.substr(node::kSourcePreparing.size());
}

void PipelineSession::stop() {
  if (supervisor_) supervisor_->stop();
}

std::optional<pipeline::PipelineGeometry> PipelineSession::geometry() {
  try {
    geometry_->poll();
  } catch (const node::FrameError&) {
    // A bad geometry on the topic: the one held (if any) stays; the services report it.
  }
  return geometry_->geometry();
}

const std::vector<sim::TargetTruth>& PipelineSession::truth_at(std::uint64_t seq) {
  const bool cycled = options_.prerender > 0;
  const std::int64_t frame =
      cycled ? static_cast<std::int64_t>(seq % options_.prerender) : static_cast<std::int64_t>(seq);
  if (const auto it = truth_by_frame_.find(frame); it != truth_by_frame_.end()) return it->second;
  if (!cycled) {
    // Live rendering: frames do not come back once both their ranges and obstacles are in.
    while (!truth_by_frame_.empty() && truth_by_frame_.begin()->first + 8 < frame)
      truth_by_frame_.erase(truth_by_frame_.begin());
  }
  return truth_by_frame_.emplace(frame, sim_->truth(frame)).first->second;
}

const std::vector<std::pair<cv::Rect, double>>& PipelineSession::grid_truth_at(
    std::uint64_t seq, const pipeline::PipelineGeometry& g, const Eigen::Vector3d& down) {
  const bool cycled = options_.prerender > 0;
  const std::int64_t frame =
      cycled ? static_cast<std::int64_t>(seq % options_.prerender) : static_cast<std::int64_t>(seq);
  if (const auto it = grid_truth_by_frame_.find(frame); it != grid_truth_by_frame_.end())
    return it->second;
  if (!cycled) {
    while (!grid_truth_by_frame_.empty() && grid_truth_by_frame_.begin()->first + 8 < frame)
      grid_truth_by_frame_.erase(grid_truth_by_frame_.begin());
  }
  std::vector<std::pair<cv::Rect, double>> seen;
  for (const sim::TargetTruth& t : truth_at(seq)) {
    double nearest = 1e300;
    for (const Eigen::Vector3d& p : t.surface_points_m)
      nearest = std::min(nearest, (p - down.dot(p) * down).norm());
    seen.emplace_back(pipeline::points_box_on_grid(g, pipeline::Band::visible, t.surface_points_m),
                      nearest);
  }
  return grid_truth_by_frame_.emplace(frame, std::move(seen)).first->second;
}

void PipelineSession::kill_service(const std::string& name) {
  for (const auto& status : supervisor_->services()) {
    if (status.name != name) continue;
    if (status.pid <= 0 || status.state != process::ServiceState::running)
      throw std::invalid_argument("service '" + name + "' is not running");
    killed_ns_.push_back(transport::now_ns());
    killed_at_.push_back(std::chrono::steady_clock::now());
    const auto last = name == kObstacleService ? last_obstacle_arrival_ : last_arrival_;
    last_before_kill_.push_back(last == std::chrono::steady_clock::time_point{} ? killed_at_.back()
                                                                                : last);
    outages_.push_back({name});
    ::kill(status.pid, SIGKILL);
    return;
  }
  throw std::invalid_argument("no service '" + name + "' in the manifest");
}

void PipelineSession::note_arrival(bool obstacles, std::int64_t capture_ns,
                                   std::chrono::steady_clock::time_point arrival) {
  for (std::size_t k = 0; k < outages_.size(); ++k) {
    // The obstacle service's outage ends with obstacles, every other one with ranges.
    if ((outages_[k].service == kObstacleService) != obstacles) continue;
    // The first result of a frame captured after the kill ends the outage.
    if (outages_[k].recovered || capture_ns <= killed_ns_[k]) continue;
    outages_[k].recovered = true;
    outages_[k].first_fresh_ms =
        std::chrono::duration<double, std::milli>(arrival - killed_at_[k]).count();
    // From the last result received before the kill (a frame already past the killed stage,
    // or an old one the restarted service found, may still arrive in between).
    outages_[k].outage_ms =
        std::chrono::duration<double, std::milli>(arrival - last_before_kill_[k]).count();
  }
}

std::vector<CheckedRange> PipelineSession::step() {
  std::vector<CheckedRange> out;
  for (const RangeArray& array : supervisor_->step()) {
    ++frames_;
    const auto arrival = std::chrono::steady_clock::now();
    note_arrival(false, array.capture_time_ns(), arrival);
    last_arrival_ = arrival;
    const double latency = transport::latency_ms(array.stamps(), array.capture_time_ns());
    const std::vector<sim::TargetTruth>& truth = truth_at(array.frame_seq());
    for (const TargetRange& range : array.targets()) {
      CheckedRange c;
      c.seq = array.frame_seq();
      c.latency_ms = latency;
      c.range = range;
      if (const sim::TargetTruth* t = truth_on_line_of_sight(
              truth, Eigen::Vector3d(range.x_m(), range.y_m(), range.z_m()))) {
        c.truth = summary_of(*t);
        c.error_m = range.distance_m() - t->distance_m;
      }
      out.push_back(c);
      checked_.push_back(c);
    }
  }
  return out;
}

std::vector<CheckedObstacle> PipelineSession::step_obstacles() {
  std::vector<CheckedObstacle> out;
  auto arrays = obstacles_in_->take();
  if (arrays.size() == 0) return out;
  const auto g = geometry();
  if (!g) return out;  // no truth without the reporting camera's pose
  // The simulated rig is level: the ground's normal in the reporting camera's frame.
  const Eigen::Vector3d down =
      obstacle::plane_in_frame(obstacle::prior_plane(obstacle::GroundPrior{}), g->T_ref_reporting)
          .normal;
  const auto horizontal = [&](const Eigen::Vector3d& p) { return (p - down.dot(p) * down).norm(); };
  for (std::size_t i = 0; i < arrays.size(); ++i) {
    const ObstacleArray& array = arrays[i];
    const auto arrival = std::chrono::steady_clock::now();
    note_arrival(true, array.capture_time_ns(), arrival);
    last_obstacle_arrival_ = arrival;
    ++obstacle_frames_;
    const double latency = transport::latency_ms(array.stamps(), array.capture_time_ns());
    obstacle_latency_ms_.push_back(latency);
    const std::vector<sim::TargetTruth>& truth = truth_at(array.frame_seq());
    for (const Obstacle& o : array.obstacles()) {
      CheckedObstacle c;
      c.seq = array.frame_seq();
      c.obstacle = o;
      c.latency_ms = latency;
      if (o.has_target()) {
        // A ranged target: the simulated target on its range's line of sight, as its range
        // line has it, at its centre's horizontal distance.
        if (const sim::TargetTruth* t =
                truth_on_line_of_sight(truth, Eigen::Vector3d(o.x_m(), o.y_m(), o.z_m()))) {
          c.truth = summary_of(*t);
          c.truth_distance_m = horizontal(t->position_m);
          c.error_m = o.distance_m() - c.truth_distance_m;
        }
      } else {
        // Of the targets whose silhouette's box on the grid overlaps the obstacle's (a fifth of
        // the smaller), the one at its distance within 15 % + 0.5 m, as `bench obstacles`
        // counts them; one farther off is another object before or behind it.
        const cv::Rect box = node::to_rect(o.box());
        const auto& seen = grid_truth_at(array.frame_seq(), *g, down);
        for (std::size_t k = 0; k < truth.size() && k < seen.size(); ++k) {
          const auto& [truth_box, d] = seen[k];
          if ((truth_box & box).area() <= 0.2 * std::min(truth_box.area(), box.area())) continue;
          const double error = o.distance_m() - d;
          if (std::abs(error) > kObstacleTruthToleranceM + kObstacleTruthToleranceShare * d) {
            continue;
          }
          if (!c.truth || std::abs(error) < std::abs(c.error_m)) {
            c.truth = summary_of(truth[k]);
            c.truth_distance_m = d;
            c.error_m = error;
          }
        }
      }
      out.push_back(c);
      checked_obstacles_.push_back(c);
    }
  }
  return out;
}

void PipelineSession::reset_statistics() {
  step();
  step_obstacles();
  supervisor_->reset_statistics();
  frames_ = 0;
  obstacle_frames_ = 0;
  checked_.clear();
  checked_obstacles_.clear();
  obstacle_latency_ms_.clear();
  cpu_marks_.mark(supervisor_->services());
}

std::vector<ProcessCpu> PipelineSession::cpu() const {
  return cpu_marks_.since(supervisor_->services());
}

bool CpuMarks::usage(int pid, double& cpu_s, double& rss_bytes) const {
  return pid > 0 && (whole_group_ ? read_group_usage(pid, cpu_s, rss_bytes)
                                  : read_process_usage(pid, cpu_s, rss_bytes));
}

void CpuMarks::mark(const std::vector<process::ServiceStatus>& services) {
  marks_.clear();
  for (const auto& status : services) {
    Mark mark;
    double rss = 0;
    if (usage(status.pid, mark.cpu_s, rss)) {
      mark.wall_s = wall_seconds();
      marks_[status.pid] = mark;
    }
  }
}

std::vector<ProcessCpu> CpuMarks::since(const std::vector<process::ServiceStatus>& services) const {
  std::vector<ProcessCpu> out;
  for (const auto& status : services) {
    ProcessCpu p;
    p.service = status.name;
    double cpu_s = 0, rss = 0;
    if (usage(status.pid, cpu_s, rss)) {
      const auto mark = marks_.find(status.pid);
      const Mark from = mark == marks_.end() ? Mark{} : mark->second;
      const double wall = wall_seconds() - from.wall_s;
      // Without a mark (restarted since) the figure is over the process's life: unknown here.
      const bool known = mark != marks_.end() && wall > 0;
      p.cpu_s = known ? cpu_s - from.cpu_s : std::nan("");
      p.cpu_percent = known ? 100.0 * p.cpu_s / wall : std::nan("");
      p.rss_mb = rss / 1e6;
      p.scheduling = read_scheduling(status.pid);
    }
    out.push_back(p);
  }
  return out;
}

RangeErrorSummary PipelineSession::errors() const {
  RangeErrorSummary s;
  s.frames = frames_;
  s.ranges = checked_.size();
  std::vector<double> abs_errors;
  double relative = 0;
  std::map<std::string, RangeErrorSummary::PerTarget> per;
  for (const CheckedRange& c : checked_) {
    if (!c.truth) continue;
    abs_errors.push_back(std::abs(c.error_m));
    relative += std::abs(c.error_m) / c.truth->distance_m;
    auto& t = per[c.truth->id];
    t.id = c.truth->id;
    t.truth_m += c.truth->distance_m;
    t.mean_error_m += c.error_m;
    t.mean_sigma_m += c.range.sigma_m();
    ++t.ranges;
  }
  s.matched = abs_errors.size();
  if (!abs_errors.empty()) {
    double sum = 0;
    for (double e : abs_errors) sum += e;
    s.mean_abs_error_m = sum / static_cast<double>(abs_errors.size());
    s.mean_abs_relative_error = relative / static_cast<double>(abs_errors.size());
    s.p95_abs_error_m = metrics::percentile(abs_errors, 95);
    s.max_abs_error_m = *std::max_element(abs_errors.begin(), abs_errors.end());
  }
  for (auto& [id, t] : per) {
    const double n = static_cast<double>(t.ranges);
    t.truth_m /= n;
    t.mean_error_m /= n;
    t.mean_sigma_m /= n;
    s.targets.push_back(t);
  }
  std::sort(s.targets.begin(), s.targets.end(),
            [](const auto& a, const auto& b) { return a.truth_m < b.truth_m; });
  return s;
}

ObstacleErrorSummary PipelineSession::obstacle_errors() const {
  ObstacleErrorSummary s;
  s.frames = obstacle_frames_;
  s.obstacles = checked_obstacles_.size();
  std::vector<double> abs_errors, relative;
  std::map<std::string, std::pair<std::vector<double>, std::vector<double>>> per;  // truths, errors
  for (const CheckedObstacle& c : checked_obstacles_) {
    s.targets += c.obstacle.has_target();
    if (!c.truth) continue;
    abs_errors.push_back(std::abs(c.error_m));
    relative.push_back(std::abs(c.error_m) / c.truth_distance_m);
    auto& [truths, errors] = per[c.truth->id];
    truths.push_back(c.truth_distance_m);
    errors.push_back(c.error_m);
  }
  if (!obstacle_latency_ms_.empty()) {
    s.latency_p50_ms = metrics::percentile(obstacle_latency_ms_, 50);
    s.latency_p99_ms = metrics::percentile(obstacle_latency_ms_, 99);
  }
  s.matched = abs_errors.size();
  if (!abs_errors.empty()) {
    s.median_abs_error_m = metrics::percentile(abs_errors, 50);
    s.median_abs_relative_error = metrics::percentile(relative, 50);
  }
  for (auto& [id, te] : per) {
    ObstacleErrorSummary::PerTarget t;
    t.id = id;
    t.truth_m = metrics::percentile(te.first, 50);
    t.found = te.second.size();
    t.median_error_m = metrics::percentile(te.second, 50);
    s.targets_found.push_back(t);
  }
  std::sort(s.targets_found.begin(), s.targets_found.end(),
            [](const auto& a, const auto& b) { return a.truth_m < b.truth_m; });
  return s;
}

std::string obstacle_line(const CheckedObstacle& c) {
  const Obstacle& o = c.obstacle;
  std::ostringstream out;
  out << "frame " << std::setw(6) << c.seq << "  " << std::setw(8) << o.label().to_string() << " #"
      << std::setw(2) << std::left << o.obstacle_id() << std::right << "  " << std::setw(7)
      << fixed(o.distance_m(), 2) << " m +- " << fixed(o.sigma_m(), 2) << "  ("
      << fixed(o.width_m(), 1) << " x " << fixed(o.height_m(), 1) << " m, " << o.stixels()
      << " stixels)";
  if (c.truth) {
    out << "  truth " << std::setw(7) << fixed(c.truth_distance_m, 2) << " m (" << c.truth->id
        << ")  error " << (c.error_m >= 0 ? "+" : "") << fixed(c.error_m, 2) << " m";
  } else {
    out << "  truth: no simulated target in this direction";
  }
  out << "  latency " << fixed(c.latency_ms, 1) << " ms";
  return out.str();
}

std::string obstacle_json(const CheckedObstacle& c) {
  const Obstacle& o = c.obstacle;
  nlohmann::json j{{"kind", "obstacle"},
                   {"frame_seq", c.seq},
                   {"obstacle_id", o.obstacle_id()},
                   {"label", o.label().to_string()},
                   {"target_id", o.has_target() ? nlohmann::json(o.target_id()) : nlohmann::json()},
                   {"distance_m", o.distance_m()},
                   {"sigma_m", o.sigma_m()},
                   {"position_m", {o.x_m(), o.y_m(), o.z_m()}},
                   {"extent_m", {o.width_m(), o.height_m(), o.depth_m()}},
                   {"box", {o.box().x(), o.box().y(), o.box().width(), o.box().height()}},
                   {"band", o.band()},
                   {"stixels", o.stixels()},
                   {"latency_ms", c.latency_ms}};
  if (c.truth) {
    j["truth_id"] = c.truth->id;
    j["truth_distance_m"] = c.truth_distance_m;
    j["error_m"] = c.error_m;
  } else {
    j["truth_id"] = nullptr;
  }
  return j.dump();
}

std::string obstacle_errors_text(const ObstacleErrorSummary& s) {
  std::ostringstream out;
  out << "obstacles " << s.obstacles << " in " << s.frames << " results (capture to obstacles p50 "
      << fixed(s.latency_p50_ms, 1) << " ms, p99 " << fixed(s.latency_p99_ms, 1) << " ms; "
      << s.targets << " ranged targets), " << s.matched << " on a simulated target; |error| median "
      << fixed(s.median_abs_error_m, 2) << " m (" << fixed(100.0 * s.median_abs_relative_error, 1)
      << " %)\n";
  for (const auto& t : s.targets_found) {
    out << "  " << std::setw(14) << t.id << "  truth " << std::setw(6) << fixed(t.truth_m, 2)
        << " m  found " << std::setw(5) << t.found << "  median error "
        << (t.median_error_m >= 0 ? "+" : "") << fixed(t.median_error_m, 2) << " m\n";
  }
  return out.str();
}

std::string range_line(const CheckedRange& c) {
  const TargetRange& r = c.range;
  std::ostringstream out;
  out << "frame " << std::setw(6) << c.seq << "  " << std::setw(8) << r.label().to_string() << " #"
      << std::setw(2) << std::left << r.target_id() << std::right << "  " << std::setw(7)
      << fixed(r.distance_m(), 2) << " m +- " << fixed(r.sigma_m(), 2) << "  (" << r.point_count()
      << " points)";
  if (c.truth) {
    out << "  truth " << std::setw(7) << fixed(c.truth->distance_m, 2) << " m (" << c.truth->id
        << ")  error " << (c.error_m >= 0 ? "+" : "") << fixed(c.error_m, 2) << " m";
  } else {
    out << "  truth: no simulated target in this direction";
  }
  out << "  latency " << fixed(c.latency_ms, 1) << " ms";
  return out.str();
}

std::string range_json(const CheckedRange& c) {
  const TargetRange& r = c.range;
  nlohmann::json j{{"kind", "range"},
                   {"frame_seq", c.seq},
                   {"target_id", r.target_id()},
                   {"label", r.label().to_string()},
                   {"distance_m", r.distance_m()},
                   {"sigma_m", r.sigma_m()},
                   {"position_m", {r.x_m(), r.y_m(), r.z_m()}},
                   {"box", {r.box().x(), r.box().y(), r.box().width(), r.box().height()}},
                   {"point_count", r.point_count()},
                   {"latency_ms", c.latency_ms}};
  if (c.truth) {
    j["truth_id"] = c.truth->id;
    j["truth_distance_m"] = c.truth->distance_m;
    j["error_m"] = c.error_m;
  } else {
    j["truth_id"] = nullptr;
  }
  return j.dump();
}

nlohmann::json summary_json(const supervisor::LatencySummary& latency,
                            const RangeErrorSummary& errors,
                            const ObstacleErrorSummary* obstacles) {
  auto j = nlohmann::json::parse(supervisor::summary_json(latency));
  if (obstacles != nullptr) {
    j["obstacle_frames"] = obstacles->frames;
    j["obstacles"] = obstacles->obstacles;
    j["obstacles_on_target"] = obstacles->matched;
    j["obstacle_median_abs_error_m"] = obstacles->median_abs_error_m;
    j["obstacle_latency_p50_ms"] = obstacles->latency_p50_ms;
    j["obstacle_latency_p99_ms"] = obstacles->latency_p99_ms;
  }
  j["ranges"] = errors.ranges;
  j["ranges_on_target"] = errors.matched;
  j["mean_abs_error_m"] = errors.mean_abs_error_m;
  j["p95_abs_error_m"] = errors.p95_abs_error_m;
  j["mean_abs_relative_error"] = errors.mean_abs_relative_error;
  return j;
}

std::string errors_text(const RangeErrorSummary& s) {
  std::ostringstream out;
  out << "ranges " << s.ranges << " in " << s.frames << " results, " << s.matched
      << " on a simulated target; |error| mean " << fixed(s.mean_abs_error_m, 3) << " m ("
      << fixed(100.0 * s.mean_abs_relative_error, 2) << " %), p95 " << fixed(s.p95_abs_error_m, 3)
      << " m, max " << fixed(s.max_abs_error_m, 3) << " m\n";
  for (const auto& t : s.targets) {
    out << "  " << std::setw(10) << t.id << "  truth " << std::setw(6) << fixed(t.truth_m, 2)
        << " m  ranges " << std::setw(5) << t.ranges << "  mean error "
        << (t.mean_error_m >= 0 ? "+" : "") << fixed(t.mean_error_m, 3) << " m  mean sigma "
        << fixed(t.mean_sigma_m, 3) << " m\n";
  }
  return out.str();
}

}  // namespace thermovis::cli
