#pragma once
// A service's health on thermovis/health (RELIABLE + TRANSIENT_LOCAL, keyed by service name):
// state, frames processed, bad inputs and the last error, and the deadline counters of every
// topic it reads or writes. Published on every state change, when a DEADLINE miss is counted
// (at most every 50 ms) and at least once per period.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "thermovis/health.h"
#include "thermovis/node/systemd_notify.hpp"
#include "thermovis/transport/counters.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::node {

// The bridge's health message while its source prepares its captures (the simulated rig
// prerendering them): this prefix, then what it has done. A measurement waits for its end.
inline constexpr std::string_view kSourcePreparing = "source preparing: ";

// "starting", "ok", "degraded", "failed" or "stopping" ("unknown" for a value out of the enum).
const char* health_state_name(HealthState state);
// DDS deadlines missed on one topic of a health message, or on every topic of `health`, reader
// side (requested) and writer side (offered) together.
std::uint64_t deadline_misses(const TopicHealth& topic);
std::uint64_t deadline_misses(const Health& health);

// Writes "SERVICE: bad input #COUNT: MESSAGE" to stderr for the first bad inputs one by one,
// then every 100th (a flood of bad input is thinned). `count` counts this one.
void log_bad_input(const std::string& service, std::uint64_t count, const std::string& message);

class HealthReporter {
 public:
  using CountersSource = std::function<std::vector<transport::TopicCountersSnapshot>()>;

  HealthReporter(transport::Participant& participant, std::string service,
                 CountersSource counters = {},
                 std::chrono::milliseconds period = std::chrono::milliseconds(1000));

  void set_state(HealthState state, const std::string& message);
  // A new message in the same state (e.g. how far a source's preparation is), published now.
  void set_message(const std::string& message);
  void frame_processed();
  // Counts a bad input and keeps its message; the state becomes DEGRADED until `recover_after`
  // good frames have passed.
  void bad_input(const std::string& message);
  // Publishes if the period has passed since the last publication, or a DEADLINE miss has been
  // counted since (at most every 50 ms). Called from the service's
  // processing loop, it also tells systemd (Type=notify units) that the service is ready, the
  // first time, and pings its watchdog.
  void tick();
  void publish_now();

  std::uint64_t frames_processed() const;
  std::uint32_t errors() const;

 private:
  transport::Writer<Health> writer_;
  std::string service_;
  CountersSource counters_;
  std::chrono::milliseconds period_;
  mutable std::mutex mutex_;
  HealthState state_ = HEALTH_STARTING;
  std::string message_;
  std::uint64_t frames_ = 0;
  std::uint32_t errors_ = 0;
  std::uint64_t good_since_error_ = 0;
  std::chrono::steady_clock::time_point last_publish_{};
  std::atomic<std::uint64_t> published_misses_{0};  // DEADLINE misses in the last publication
  SystemdNotifier systemd_;
};

// For a FrameReader (transport/frames.hpp): a packed frame that does not unpack is bad input,
// counted in `count` and reported through `health` like a bad frame of the plain topic.
inline std::function<void(const std::string&)> count_bad_input(std::uint64_t& count,
                                                               HealthReporter& health) {
  return [&count, &health](const std::string& why) {
    ++count;
    health.bad_input(why);
  };
}

}  // namespace thermovis::node
