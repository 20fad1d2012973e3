// Faults and endurance of the whole pipeline as users run it (thermovis-supervisor with the
// shipped manifest on a private DDS domain, loopback profile). The test is another DDS
// application: it receives thermovis/ranges and thermovis/health and judges from that data.
//
// - Every service killed with SIGKILL in turn: the supervisor restarts it, the others keep
//   their pids, ranges resume; the outage (last range before the gap to the first range of a
//   frame captured after the kill) and where it goes (respawn, first health of the new process,
//   first fresh range) are recorded as test properties.
// - The bridge stopped (SIGTERM) and started again by hand: the downstream services wait and
//   resume with the same pids.
// - Soak: memory, open descriptors and mapped shared-memory segments of every service flat after
//   a warm-up, and every published frame accounted for (processed and published downstream, or
//   dropped) from the health counters. $THERMOVIS_SOAK_SECONDS sets the length (45 s default).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <numeric>
#include <thread>

#include "faults_harness.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/transport/shared_memory.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::Clock;
using thermovis::test::ms_between;
using thermovis::test::PipelineWatcher;
namespace tv = thermovis;

// Pools of the processes this test killed stay in /dev/shm until someone removes them.
void remove_segments_of_dead_processes() { tv::transport::remove_stale_data_sharing_segments(); }

struct Outage {
  double respawn_ms = -1, health_ms = -1, first_fresh_ms = -1, outage_ms = -1;
};

// After `stopped_at` (steady) / `stopped_wall_ns` (capture clock): waits for a new process of
// `service` (other than `old_pid`), its first health, and the first range of a frame captured
// after the stop. Fields stay -1 when not seen within `timeout`.
Outage watch_recovery(PipelineWatcher& watcher, int domain, const std::string& service,
                      pid_t old_pid, Clock::time_point stopped_at, std::int64_t stopped_wall_ns,
                      std::chrono::seconds timeout) {
  Outage o;
  const std::string key = "thermovis-" + service;
  Clock::time_point respawned{};
  const std::size_t seen_before = watcher.arrivals().size();
  for (const auto until = stopped_at + timeout; Clock::now() < until;) {
    watcher.poll(5ms);
    const auto now = Clock::now();
    if (respawned == Clock::time_point{}) {
      const pid_t pid = tv::test::service_pid(service, domain);
      if (pid > 0 && pid != old_pid) {
        respawned = now;
        o.respawn_ms = ms_between(stopped_at, now);
      }
    }
    if (respawned != Clock::time_point{} && o.health_ms < 0 && watcher.health_seen(key) > respawned)
      o.health_ms = ms_between(stopped_at, watcher.health_seen(key));
    const auto& a = watcher.arrivals();
    for (std::size_t i = seen_before; i < a.size(); ++i) {
      if (a[i].capture_ns <= stopped_wall_ns) continue;
      o.first_fresh_ms = ms_between(stopped_at, a[i].at);
      // From the last result received before the stop (results of frames already past the
      // stopped stage, or of an old frame a restarted service found, may arrive in between).
      Clock::time_point last_before = stopped_at;
      for (std::size_t j = seen_before; j-- > 0;) {
        if (a[j].at <= stopped_at) {
          last_before = a[j].at;
          break;
        }
      }
      o.outage_ms = ms_between(last_before, a[i].at);
      return o;
    }
  }
  return o;
}

TEST(Faults, EveryServiceKilledOrStoppedComesBackAndRangesResume) {
  const auto dir = tv::test::temp_dir("faults_kill");
  const int domain = tv::test::private_domain();
  // The watcher first: matched before the first range is published, it misses none.
  PipelineWatcher watcher(domain);
  tv::test::ChildProcess supervisor(tv::test::supervisor_command(dir, domain),
                                    dir / "supervisor.log");
  ASSERT_TRUE(watcher.wait_for_results(20, Clock::now() + 180s)) << supervisor.log();

  int collateral = 0;  // restarts of a service other than the one killed
  for (const std::string& service : tv::test::pipeline_services()) {
    SCOPED_TRACE(service);
    const auto before = tv::test::service_pids(domain);
    for (const auto& [name, pid] : before) ASSERT_GT(pid, 0) << name << " is not running";
    const pid_t victim = before.at(service);
    ::kill(victim, SIGKILL);
    const auto killed = Clock::now();
    const std::int64_t killed_ns = tv::transport::now_ns();
    const Outage o = watch_recovery(watcher, domain, service, victim, killed, killed_ns, 60s);
    ASSERT_GE(o.first_fresh_ms, 0) << "no ranges within 60 s after killing " << service << "\n"
                                   << supervisor.log();
    std::cout << service << " killed: respawned after " << o.respawn_ms << " ms, health after "
              << o.health_ms << " ms, first fresh range after " << o.first_fresh_ms
              << " ms; outage " << o.outage_ms << " ms" << std::endl;
    RecordProperty(service + "_outage_ms", static_cast<int>(o.outage_ms));
    RecordProperty(service + "_respawn_ms", static_cast<int>(o.respawn_ms));
    RecordProperty(service + "_health_ms", static_cast<int>(o.health_ms));
    RecordProperty(service + "_first_fresh_ms", static_cast<int>(o.first_fresh_ms));
    // Ranges keep flowing, from the restarted service and the same other processes.
    const std::size_t now = watcher.arrivals().size();
    EXPECT_TRUE(watcher.wait_for_results(now + 15, Clock::now() + 60s))
        << "ranges did not keep flowing after " << service << " came back";
    const auto after = tv::test::service_pids(domain);
    for (const auto& [name, pid] : after) {
      if (name == service) {
        EXPECT_GT(pid, 0);
        EXPECT_NE(pid, victim) << "not restarted";
      } else if (service == "bridge" && name == "rectify-fuse" && pid != before.at(name)) {
        // Known Fast DDS 2.9 limit (docs/services.md, faults): a writer killed while it held its
        // reader's data-sharing notification mutex (not robust) wedges it; the reader and the
        // new writer both time out on it and the supervisor restarts them.
        ++collateral;
        std::cout << "rectify-fuse restarted with the killed bridge" << std::endl;
        RecordProperty("rectify_fuse_restarted_with_bridge", 1);
      } else {
        EXPECT_EQ(pid, before.at(name)) << name << " did not keep running";
      }
    }
  }

  // The bridge stopped cleanly (the supervisor leaves a service that exits with 0 stopped),
  // then started again by hand: the others wait and resume without a restart.
  const auto before = tv::test::service_pids(domain);
  const pid_t bridge = before.at("bridge");
  ::kill(bridge, SIGTERM);
  const auto stopped = Clock::now();
  const std::int64_t stopped_ns = tv::transport::now_ns();
  while (tv::test::service_pid("bridge", domain) == bridge && Clock::now() - stopped < 30s)
    watcher.poll(10ms);
  ASSERT_EQ(tv::test::service_pid("bridge", domain), 0) << "the bridge did not stop";
  // Downstream keeps waiting for frames (two seconds without any).
  for (const auto until = Clock::now() + 2s; Clock::now() < until;) watcher.poll(50ms);
  for (const auto& [name, pid] : tv::test::service_pids(domain)) {
    if (name != "bridge") {
      EXPECT_EQ(pid, before.at(name)) << name << " did not wait";
    }
  }
  tv::test::ChildProcess new_bridge(
      {(tv::test::bin_dir() / "thermovis-bridge").string(), "--domain", std::to_string(domain),
       "--profile", tv::transport::kLoopbackProfile, "--source", "sim", "--scene",
       (tv::test::source_root() / "deploy/scenes/paper.yaml").string()},
      dir / "bridge-by-hand.log");
  const Outage o = watch_recovery(watcher, domain, "bridge", bridge, stopped, stopped_ns,
                                  std::chrono::seconds(60));
  ASSERT_GE(o.first_fresh_ms, 0) << "no ranges after the bridge came back\n"
                                 << new_bridge.log() << supervisor.log();
  std::cout << "bridge stopped and started again: ranges after " << o.first_fresh_ms << " ms"
            << std::endl;
  const std::size_t now = watcher.arrivals().size();
  EXPECT_TRUE(watcher.wait_for_results(now + 15, Clock::now() + 60s));
  for (const auto& [name, pid] : tv::test::service_pids(domain)) {
    if (name != "bridge") {
      EXPECT_EQ(pid, before.at(name)) << name << " did not keep running";
    }
  }

  supervisor.signal(SIGTERM);
  ASSERT_EQ(supervisor.wait(60s), 0) << supervisor.log();
  new_bridge.signal(SIGTERM);
  EXPECT_EQ(new_bridge.wait(30s), 0) << new_bridge.log();
  const auto summary = tv::test::last_json_line(supervisor.log());
  ASSERT_FALSE(summary.is_null()) << supervisor.log();
  // One restart per killed service; a wedged reader also restarts the new bridge once.
  EXPECT_GE(summary["restarts"].get<int>(), 5);
  EXPECT_LE(summary["restarts"].get<int>(), 5 + 2 * collateral) << "restarts nobody caused";
  remove_segments_of_dead_processes();
  if (!HasFailure()) std::filesystem::remove_all(dir);  // else the logs tell why
}

double mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

TEST(Faults, SoakMemoryDescriptorsAndSegmentsStayFlatAndEveryFrameIsAccountedFor) {
  double seconds = 45.0;
  if (const char* env = std::getenv("THERMOVIS_SOAK_SECONDS"); env != nullptr && *env != '\0')
    seconds = std::atof(env);
  ASSERT_GE(seconds, 20.0) << "THERMOVIS_SOAK_SECONDS too short to compare thirds";
  const auto dir = tv::test::temp_dir("faults_soak");
  const int domain = tv::test::private_domain();
  // The watcher first: matched before the first range is published, it misses none.
  PipelineWatcher watcher(domain);
  tv::test::ChildProcess supervisor(tv::test::supervisor_command(dir, domain),
                                    dir / "supervisor.log");
  ASSERT_TRUE(watcher.wait_for_results(5, Clock::now() + 180s)) << supervisor.log();
  const auto pids = tv::test::service_pids(domain);
  for (const auto& [name, pid] : pids) ASSERT_GT(pid, 0) << name;

  // Warm-up (pools, heap and caches reach their working size), then one sample every second.
  const double warmup_s = std::min(10.0, seconds / 4);
  const auto start = Clock::now();
  const auto measure_from = start + std::chrono::duration<double>(warmup_s);
  const auto end = start + std::chrono::duration<double>(seconds);
  std::map<std::string, std::vector<tv::test::ProcessUsage>> usage;
  auto next_sample = measure_from;
  while (Clock::now() < end) {
    watcher.poll(50ms);
    if (Clock::now() < next_sample) continue;
    next_sample += 1s;
    for (const auto& [name, pid] : pids) usage[name].push_back(tv::test::process_usage(pid));
  }
  for (const auto& [name, pid] : tv::test::service_pids(domain))
    ASSERT_EQ(pid, pids.at(name)) << name << " restarted during the soak\n" << supervisor.log();

  for (const auto& [name, samples] : usage) {
    SCOPED_TRACE(name);
    ASSERT_GE(samples.size(), 6u);
    const std::size_t third = samples.size() / 3;
    std::vector<double> first_rss, last_rss;
    std::size_t first_fds = 0, first_segments = 0, last_fds = 0, last_segments = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      ASSERT_TRUE(samples[i].alive);
      if (i < third) {
        first_rss.push_back(samples[i].rss_mb);
        first_fds = std::max(first_fds, samples[i].fds);
        first_segments = std::max(first_segments, samples[i].shm_segments);
      } else if (i >= samples.size() - third) {
        last_rss.push_back(samples[i].rss_mb);
        last_fds = std::max(last_fds, samples[i].fds);
        last_segments = std::max(last_segments, samples[i].shm_segments);
      }
    }
    const double growth_mb = mean(last_rss) - mean(first_rss);
    std::cout << name << ": rss " << mean(first_rss) << " -> " << mean(last_rss) << " MB, fds "
              << first_fds << " -> " << last_fds << ", shm segments " << first_segments << " -> "
              << last_segments << std::endl;
    RecordProperty(name + "_rss_growth_kb", static_cast<int>(growth_mb * 1024));
    // A leak of one frame buffer per second (~1-6 MB) over the soak would exceed this.
    EXPECT_LT(growth_mb, std::max(8.0, 0.05 * mean(first_rss))) << "memory grows";
    EXPECT_LE(last_fds, first_fds) << "open descriptors grow";
    EXPECT_LE(last_segments, first_segments) << "mapped shared-memory segments grow";
  }

  // Accounting: stop the bridge, let the frames in flight drain, then compare the counters of
  // each stage along the path every range takes (bridge -> rectify-fuse -> detect -> match ->
  // range -> this test). Every frame a stage processed was published downstream; the rest
  // were dropped (taken and skipped for a newer one, or overwritten in the pool unread).
  ::kill(pids.at("bridge"), SIGTERM);
  std::map<std::string, std::uint64_t> previous;
  int stable_polls = 0;
  for (const auto until = Clock::now() + 60s; Clock::now() < until && stable_polls < 3;) {
    for (const auto poll_until = Clock::now() + 1500ms; Clock::now() < poll_until;)
      watcher.poll(50ms);
    std::map<std::string, std::uint64_t> counts;
    for (const auto& [service, h] : watcher.last_health()) counts[service] = h.frames_processed();
    counts["results"] = watcher.arrivals().size();
    stable_polls = counts == previous ? stable_polls + 1 : 0;
    previous = counts;
  }
  ASSERT_GE(stable_polls, 3) << "counters did not settle after the bridge stopped";
  const auto& health = watcher.last_health();
  for (const char* s : {"thermovis-bridge", "thermovis-rectify-fuse", "thermovis-detect",
                        "thermovis-match", "thermovis-range"})
    ASSERT_EQ(health.count(s), 1u) << s << " never reported health";
  namespace topics = tv::transport::topics;
  using tv::test::topic_samples;
  const auto& bridge = health.at("thermovis-bridge");
  const auto& rectify = health.at("thermovis-rectify-fuse");
  const auto& detect = health.at("thermovis-detect");
  const auto& match = health.at("thermovis-match");
  const auto& range = health.at("thermovis-range");
  const std::uint64_t published = topic_samples(bridge, topics::kInfraredFrames);
  const std::uint64_t results = watcher.arrivals().size();
  ASSERT_GT(published, static_cast<std::uint64_t>(10 * seconds)) << "the bridge barely ran";
  // Each stage: what it processed it published, and it never saw more than was published.
  struct Stage {
    const char* name;
    const tv::Health& health;
    const char* in;
    std::uint64_t upstream_published;
    const char* out;
  };
  const std::vector<Stage> stages{
      {"rectify-fuse", rectify, topics::kInfraredFrames, published, topics::kRectifiedInfrared},
      {"detect", detect, topics::kRectifiedInfrared,
       topic_samples(rectify, topics::kRectifiedInfrared), topics::kDetections},
      {"match", match, topics::kDetections, topic_samples(detect, topics::kDetections),
       topics::kMatches},
      {"range", range, topics::kMatches, topic_samples(match, topics::kMatches), topics::kRanges}};
  std::uint64_t dropped = 0;
  for (const Stage& s : stages) {
    SCOPED_TRACE(s.name);
    const std::uint64_t processed = s.health.frames_processed();
    const std::uint64_t passed_on = topic_samples(s.health, s.out);
    // Every frame passed on was processed, or found bad after its result went out (a frame
    // overwritten while read is checked after processing), which the stage's errors count.
    EXPECT_GE(passed_on, processed) << "processed but not passed on";
    EXPECT_LE(passed_on, processed + s.health.errors()) << "passed on but neither processed "
                                                           "nor reported bad";
    EXPECT_LE(topic_samples(s.health, s.in), s.upstream_published) << "more received than sent";
    ASSERT_LE(passed_on, s.upstream_published) << "more passed on than came in";
    const std::uint64_t stage_dropped = s.upstream_published - passed_on;
    std::cout << s.name << ": " << s.upstream_published << " in, " << processed << " processed, "
              << passed_on << " passed on, " << stage_dropped << " dropped" << std::endl;
    RecordProperty(std::string(s.name) + "_dropped", static_cast<int>(stage_dropped));
    dropped += stage_dropped;
  }
  // The last hop: every range the range service published reached this application.
  EXPECT_EQ(results, topic_samples(range, topics::kRanges)) << "results lost on the way here";
  std::cout << "published " << published << " = " << results << " ranged + " << dropped
            << " dropped on the way" << std::endl;
  EXPECT_GT(results, static_cast<std::uint64_t>(seconds)) << "fewer than one result a second";

  supervisor.signal(SIGTERM);
  ASSERT_EQ(supervisor.wait(60s), 0) << supervisor.log();
  const auto summary = tv::test::last_json_line(supervisor.log());
  ASSERT_FALSE(summary.is_null());
  // Every service kept its process through the soak (the pid check above). Before it,
  // thermovis-obstacles (SCHED_IDLE, starved while the others start) was once seen to abort as
  // it started, inside Fast DDS 2.9.1 (ReaderPool::init_shared_segment: "Assertion
  // `next_payload_ == end()' failed"), and was restarted in 0.1 s (docs/LIMITS.md, open
  // questions): once is tolerated for it, no restart at all for the target path.
  int obstacle_restarts = 0;
  if (summary["restarted"].contains("obstacles"))
    obstacle_restarts = summary["restarted"]["obstacles"]["restarts"].get<int>();
  EXPECT_LE(obstacle_restarts, 1) << supervisor.log();
  EXPECT_EQ(summary["restarts"].get<int>() - obstacle_restarts, 0) << supervisor.log();
  if (!HasFailure()) std::filesystem::remove_all(dir);  // else the logs tell why
}

}  // namespace
