#include "supervisor.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "thermovis/metrics/percentile.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/shared_memory.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/util/enum_names.hpp"

namespace thermovis::supervisor {
namespace {

using Clock = std::chrono::steady_clock;

// DEADLINE miss events kept since the last reset_statistics() (LatencySummary's).
constexpr std::size_t kMaxMissEvents = 10000;

// Exits, restarts and failed starts, one line each on the supervisor's log.
void log_event(const std::string& service, const std::string& event) {
  std::cerr << "thermovis-supervisor: " << service << ": " << event << std::endl;
}

constexpr util::EnumName<Stage> kStageNames[] = {
    {STAGE_BRIDGE, "bridge"}, {STAGE_RECTIFY_FUSE, "rectify-fuse"},
    {STAGE_DETECT, "detect"}, {STAGE_MATCH, "match"},
    {STAGE_RANGE, "range"},   {STAGE_OBSTACLES, "obstacles"}};

}  // namespace

std::string health_key(const std::string& service) { return "thermovis-" + service; }

const char* stage_name(Stage stage) { return util::name_of(kStageNames, stage, "none"); }

Supervisor::Supervisor(transport::Participant& participant, process::Manifest manifest,
                       SupervisorConfig config)
    : config_(std::move(config)),
      group_(std::move(manifest), {config_.vars, config_.log_dir, log_event}),
      timing_in_(participant, transport::topics::kTiming, transport::event_topic_qos(64)),
      health_in_(participant, transport::topics::kHealth, transport::state_topic_qos()),
      ranges_in_(participant, transport::topics::kRanges, transport::event_topic_qos(64)) {}

Supervisor::~Supervisor() { stop(); }

void Supervisor::start() {
  // Pools left in /dev/shm by services killed in an earlier run would fill the tmpfs.
  const auto stale = transport::remove_stale_data_sharing_segments();
  stale_segments_removed_ = stale.count;
  if (stale.count > 0) {
    std::cerr << "thermovis-supervisor: removed " << stale.count << " stale data-sharing segments ("
              << stale.bytes / 1000000 << " MB) from /dev/shm\n";
  }
  group_.start_all();
}

void Supervisor::stop() { group_.stop_all(); }

std::vector<RangeArray> Supervisor::step() {
  group_.poll();
  take_timing();
  take_health();
  check_hung();
  std::vector<RangeArray> out;
  auto ranges = ranges_in_.take();
  for (std::size_t i = 0; i < ranges.size(); ++i) out.push_back(ranges[i]);
  return out;
}

void Supervisor::take_timing() {
  auto samples = timing_in_.take();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const FrameTiming& t = samples[i];
    // A sample with impossible stamps would skew p50/p99: counted as bad input, not measured.
    try {
      node::check_timing(t);
    } catch (const node::FrameError& e) {
      node::log_bad_input("thermovis-supervisor", ++bad_timing_,
                          std::string(transport::topics::kTiming) + ": " + e.what());
      continue;
    }
    const double latency_ms = static_cast<double>(t.output_time_ns() - t.capture_time_ns()) / 1e6;
    latencies_ms_.push_back(latency_ms);
    if (latencies_ms_.size() == 1) first_seq_ = t.frame_seq();
    last_seq_ = std::max(last_seq_, t.frame_seq());
    LateFrame late{t.frame_seq(), t.capture_time_ns(), t.output_time_ns(), latency_ms, "none", 0.0};
    for (const StageStamp& stamp : t.stamps().stamps()) {
      if (stamp.stage() == STAGE_NONE) continue;
      const double ms = stamp.duration_us() / 1000.0;
      StageSamples& stage = stage_ms_[stamp.stage()];
      stage.own_ms.push_back(ms);
      stage.done_ms.push_back(static_cast<double>(stamp.end_ns() - t.capture_time_ns()) / 1e6);
      if (ms > late.slowest_stage_ms) {
        late.slowest_stage_ms = ms;
        late.slowest_stage = stage_name(stamp.stage());
      }
    }
    if (latency_ms > config_.latency_deadline_ms) late_.push_back(late);
  }
}

void Supervisor::take_health() {
  auto samples = health_in_.take();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::string service = samples[i].service().to_string();
    record_misses(health_.count(service) ? &health_[service] : nullptr, samples[i]);
    health_[service] = samples[i];
    last_health_[service] = Clock::now();
  }
}

void Supervisor::record_misses(const Health* before, const Health& now) {
  for (const TopicHealth& topic : now.topics()) {
    const std::uint64_t misses = node::deadline_misses(topic);
    std::uint64_t earlier = 0;
    if (before != nullptr) {
      for (const TopicHealth& t : before->topics())
        if (t.topic() == topic.topic()) earlier = node::deadline_misses(t);
    }
    // Fewer than before: a new process of the service, counting from zero again.
    const std::uint64_t added = misses >= earlier ? misses - earlier : misses;
    // A long run with an input gone misses every period: its first events are kept, not all.
    if (added == 0 || miss_events_.size() >= kMaxMissEvents) continue;
    miss_events_.push_back(
        {now.time_ns(), now.service().to_string() + " " + topic.topic().to_string(), added});
  }
}

void Supervisor::check_hung() {
  const auto now = Clock::now();
  for (const auto& status : group_.status()) {
    if (status.state != process::ServiceState::running) continue;
    // A new process (first start or a restart after an exit) is judged from its own start:
    // the health of the process it replaces says nothing about it.
    auto& instance = instances_[status.name];
    if (instance.pid != status.pid) {
      instance = {status.pid, now};
      last_health_.erase(health_key(status.name));
    }
    const auto it = last_health_.find(health_key(status.name));
    const bool never = it == last_health_.end();
    const double silent_s =
        std::chrono::duration<double>(now - (never ? instance.started : it->second)).count();
    if ((never && silent_s > config_.startup_grace_s) ||
        (!never && silent_s > config_.hung_after_s)) {
      group_.restart(status.name,
                     "no health for " + std::to_string(static_cast<int>(silent_s)) + " s (hung)");
      last_health_.erase(health_key(status.name));
    }
  }
}

void Supervisor::reset_statistics() {
  take_timing();
  take_health();
  latencies_ms_.clear();
  stage_ms_.clear();
  late_.clear();
  miss_events_.clear();
  first_seq_ = last_seq_ = 0;
  base_bad_inputs_ = base_deadline_misses_ = base_bad_timing_ = 0;
  base_deadline_misses_by_endpoint_.clear();
  const LatencySummary now = summary();
  base_deadline_misses_by_endpoint_ = now.deadline_misses_by_endpoint;
  base_bad_inputs_ = now.bad_inputs;
  base_bad_timing_ = now.bad_timing;
  base_deadline_misses_ = now.deadline_misses;
  for (const auto& status : group_.status()) base_restarts_[status.name] = status.restarts;
}

LatencySummary Supervisor::summary() const {
  LatencySummary s;
  s.frames = latencies_ms_.size();
  s.p50_ms = metrics::percentile(latencies_ms_, 50);
  s.p99_ms = metrics::percentile(latencies_ms_, 99);
  s.max_ms =
      latencies_ms_.empty() ? 0.0 : *std::max_element(latencies_ms_.begin(), latencies_ms_.end());
  s.over_deadline = late_.size();
  s.deadline_miss_events = miss_events_;
  s.first_seq = first_seq_;
  s.last_seq = last_seq_;
  if (s.frames > 0)
    s.dropped = (last_seq_ - first_seq_ + 1) -
                std::min<std::uint64_t>(s.frames, last_seq_ - first_seq_ + 1);
  s.bad_timing = bad_timing_;
  s.bad_inputs = bad_timing_;
  for (const auto& [key, h] : health_) {
    s.bad_inputs += h.errors();
    for (const auto& topic : h.topics()) {
      const std::uint64_t misses = node::deadline_misses(topic);
      s.deadline_misses += misses;
      if (misses == 0) continue;
      const std::string endpoint = h.service().to_string() + " " + topic.topic().to_string();
      auto base = base_deadline_misses_by_endpoint_.find(endpoint);
      const std::uint64_t since =
          misses -
          std::min(misses, base == base_deadline_misses_by_endpoint_.end() ? 0 : base->second);
      if (since > 0) s.deadline_misses_by_endpoint[endpoint] = since;
    }
  }
  for (const auto& status : group_.status()) {
    const auto base = base_restarts_.find(status.name);
    const int restarts = status.restarts - (base == base_restarts_.end() ? 0 : base->second);
    if (restarts <= 0) continue;
    s.restarts += static_cast<std::uint64_t>(restarts);
    s.restarted.push_back({status.name, static_cast<std::uint64_t>(restarts), status.last_error});
  }
  // Counters since the last reset (a restarted service starts its counters again at zero).
  s.bad_inputs -= std::min(s.bad_inputs, base_bad_inputs_);
  s.bad_timing -= std::min(s.bad_timing, base_bad_timing_);
  s.deadline_misses -= std::min(s.deadline_misses, base_deadline_misses_);
  for (const auto& [stage, samples] : stage_ms_) {
    const std::vector<double>& own = samples.own_ms;
    s.stages.push_back({stage_name(stage), metrics::percentile(own, 50),
                        metrics::percentile(own, 99), *std::max_element(own.begin(), own.end()),
                        metrics::percentile(samples.done_ms, 50),
                        metrics::percentile(samples.done_ms, 99)});
  }
  return s;
}

std::map<std::string, std::string> default_vars(int domain, const std::string& profile,
                                                const std::string& scene) {
  const std::filesystem::path scene_path = scene.empty()
                                               ? runtime::shipped_file("scenes/paper.yaml")
                                               : runtime::scene_argument_path(scene);
  if (!std::filesystem::exists(scene_path))
    throw std::runtime_error("scene file " + scene_path.string() + " does not exist");
  return {{"bin", std::filesystem::canonical("/proc/self/exe").parent_path().string()},
          {"domain", std::to_string(domain)},
          {"profile", profile},
          {"scene", std::filesystem::absolute(scene_path).string()},
          {"prerender", "0"},
          {"grid_scale", "0.5"},
          {"fused_rate_hz", "0"}};
}

std::string summary_json(const LatencySummary& s) {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& st : s.stages)
    stages[st.stage] = {{"p50_ms", st.p50_ms},
                        {"p99_ms", st.p99_ms},
                        {"max_ms", st.max_ms},
                        {"done_p50_ms", st.done_p50_ms},
                        {"done_p99_ms", st.done_p99_ms}};
  nlohmann::json restarted = nlohmann::json::object();
  for (const auto& r : s.restarted)
    restarted[r.service] = {{"restarts", r.restarts}, {"last_error", r.last_error}};
  return nlohmann::json{{"frames", s.frames},
                        {"p50_ms", s.p50_ms},
                        {"p99_ms", s.p99_ms},
                        {"max_ms", s.max_ms},
                        {"over_deadline", s.over_deadline},
                        {"dropped", s.dropped},
                        {"deadline_misses", s.deadline_misses},
                        {"deadline_misses_by_endpoint", s.deadline_misses_by_endpoint},
                        {"bad_inputs", s.bad_inputs},
                        {"restarts", s.restarts},
                        {"restarted", restarted},
                        {"stages", stages}}
      .dump();
}

std::string summary_text(const LatencySummary& s, double deadline_ms) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(2);
  out << "frames " << s.frames << ", capture-to-output latency p50 " << s.p50_ms << " ms, p99 "
      << s.p99_ms << " ms, max " << s.max_ms << " ms; over " << deadline_ms
      << " ms: " << s.over_deadline << "; dropped " << s.dropped << "; DEADLINE QoS misses "
      << s.deadline_misses << "; bad inputs " << s.bad_inputs << "; restarts " << s.restarts
      << "\n";
  for (const auto& r : s.restarted)
    out << "  restarted " << r.service << " " << r.restarts << "x, last: " << r.last_error << "\n";
  if (!s.deadline_misses_by_endpoint.empty()) {
    out << "  DEADLINE QoS misses by service and topic:";
    for (const auto& [endpoint, misses] : s.deadline_misses_by_endpoint)
      out << " " << endpoint << " " << misses << ";";
    out << "\n";
  }
  for (const auto& st : s.stages) {
    out << "  stage " << st.stage << ": p50 " << st.p50_ms << " ms, p99 " << st.p99_ms
        << " ms, max " << st.max_ms << " ms; done after the capture p50 " << st.done_p50_ms
        << " ms, p99 " << st.done_p99_ms << " ms\n";
  }
  return out.str();
}

}  // namespace thermovis::supervisor
