#pragma once
// What the fault and soak tests share: the pids of the pipeline's services (found in /proc by
// executable and DDS domain), their resident memory, open descriptors and mapped shared-memory
// segments, and a watcher that receives thermovis/ranges and thermovis/health as any other DDS
// application would, stamping each arrival with the test's own steady clock.
#include <pthread.h>
#include <sched.h>
#include <sys/types.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "../pipeline/pipeline_harness.hpp"
#include "thermovis/health.h"
#include "thermovis/perception.h"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::test {

using Clock = std::chrono::steady_clock;

// Manifest names of the pipeline's services, upstream first.
inline const std::vector<std::string>& pipeline_services() {
  static const std::vector<std::string> names{"bridge", "rectify-fuse", "detect", "match", "range"};
  return names;
}

inline std::map<std::string, pid_t> service_pids(int domain) {
  std::map<std::string, pid_t> out;
  for (const auto& name : pipeline_services()) out[name] = service_pid(name, domain);
  return out;
}

struct ProcessUsage {
  double rss_mb = 0.0;           // resident memory (VmRSS)
  std::size_t fds = 0;           // open file descriptors
  std::size_t shm_segments = 0;  // distinct /dev/shm files it maps
  bool alive = false;
};

inline ProcessUsage process_usage(pid_t pid) {
  ProcessUsage u;
  const std::filesystem::path proc = "/proc/" + std::to_string(pid);
  std::ifstream status(proc / "status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) {
      u.rss_mb = std::stod(line.substr(6)) / 1024.0;  // kB
      u.alive = true;
    }
  }
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(proc / "fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++u.fds;
  std::set<std::string> segments;
  std::ifstream maps(proc / "maps");
  for (std::string line; std::getline(maps, line);) {
    const auto at = line.find("/dev/shm/");
    if (at != std::string::npos) segments.insert(line.substr(at));
  }
  u.shm_segments = segments.size();
  return u;
}

// A range result as the test received it.
struct Arrival {
  Clock::time_point at;
  std::uint64_t seq = 0;
  std::int64_t capture_ns = 0;  // capture stamp (transport::now_ns clock)
  std::size_t targets = 0;
};

// The watcher's participant, its receiving threads at the frame path's realtime priority where
// this process may take it (deploy/pipeline.yaml's `realtime: 10`), as an application that must
// see every result runs: beside realtime stages on a busy machine (ctest -j2) a watcher at the
// normal policy lost 1-7 of 2300 results in the soak. The calling thread keeps its policy.
inline std::unique_ptr<transport::Participant> watcher_participant(int domain) {
  int policy = SCHED_OTHER;
  sched_param saved{};
  (void)pthread_getschedparam(pthread_self(), &policy, &saved);
  sched_param fifo{};
  fifo.sched_priority = 10;
  const bool raised = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo) == 0;
  auto participant = loopback_participant(domain, "faults-test");
  if (raised) (void)pthread_setschedparam(pthread_self(), policy, &saved);
  return participant;
}

// Receives thermovis/ranges and thermovis/health on the test's own participant.
class PipelineWatcher {
 public:
  explicit PipelineWatcher(int domain)
      : participant_(watcher_participant(domain)),
        ranges_(*participant_, transport::topics::kRanges, transport::event_topic_qos(64)),
        health_(*participant_, transport::topics::kHealth, transport::state_topic_qos()) {}

  // Takes what arrived, waiting up to `wait` for a range result first.
  void poll(std::chrono::milliseconds wait = std::chrono::milliseconds(20)) {
    ranges_.wait_for_data(wait);
    auto samples = ranges_.take();
    const auto now = Clock::now();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      arrivals_.push_back(
          {now, samples[i].frame_seq(), samples[i].capture_time_ns(), samples[i].targets().size()});
    }
    auto health = health_.take();
    for (std::size_t i = 0; i < health.size(); ++i) {
      const std::string service = health[i].service().to_string();
      last_health_[service] = health[i];
      health_seen_[service] = now;
    }
  }
  // Polls until `count` range results have arrived in total, or `until`.
  bool wait_for_results(std::size_t count, Clock::time_point until) {
    while (arrivals_.size() < count && Clock::now() < until) poll(std::chrono::milliseconds(100));
    return arrivals_.size() >= count;
  }

  const std::vector<Arrival>& arrivals() const { return arrivals_; }
  const std::map<std::string, Health>& last_health() const { return last_health_; }
  // When the last health sample of `service` ("thermovis-detect") arrived.
  Clock::time_point health_seen(const std::string& service) const {
    const auto it = health_seen_.find(service);
    return it == health_seen_.end() ? Clock::time_point{} : it->second;
  }

 private:
  std::unique_ptr<transport::Participant> participant_;
  transport::Reader<RangeArray> ranges_;
  transport::Reader<Health> health_;
  std::vector<Arrival> arrivals_;
  std::map<std::string, Health> last_health_;
  std::map<std::string, Clock::time_point> health_seen_;
};

// Samples counted on `topic` in a service's health (written or received), 0 if absent.
inline std::uint64_t topic_samples(const Health& health, const std::string& topic) {
  for (const auto& t : health.topics()) {
    if (t.topic().to_string() == topic) return t.samples();
  }
  return 0;
}

inline double ms_between(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

}  // namespace thermovis::test
