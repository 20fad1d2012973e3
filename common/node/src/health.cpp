#include "thermovis/node/health.hpp"

#include <iostream>
#include <iterator>

#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::node {
namespace {

// Good frames after a bad input before the state goes back from DEGRADED to OK.
constexpr std::uint64_t kRecoverAfterFrames = 50;
// Bad inputs written to the log one by one before thinning.
constexpr std::uint32_t kLoggedErrors = 20;
// How long a stopping service waits for its readers to acknowledge its last health.
constexpr std::chrono::milliseconds kStoppingAckWait{500};

// A DEADLINE miss is published when the service sees it counted, but not oftener than this
// (an input that has stopped misses every period).
constexpr std::chrono::milliseconds kMissPublishInterval{50};

std::uint64_t misses_of(const std::vector<transport::TopicCountersSnapshot>& counters) {
  std::uint64_t misses = 0;
  for (const auto& c : counters)
    misses += std::uint64_t{c.requested_deadline_missed} + c.offered_deadline_missed;
  return misses;
}

std::string clip(const std::string& text, std::size_t max) {
  return text.size() <= max ? text : text.substr(0, max - 3) + "...";
}

}  // namespace

const char* health_state_name(HealthState state) {
  // In the order of the IDL enum (health.idl).
  static constexpr const char* kNames[] = {"starting", "ok", "degraded", "failed", "stopping"};
  const auto i = static_cast<std::size_t>(state);
  return i < std::size(kNames) ? kNames[i] : "unknown";
}

std::uint64_t deadline_misses(const TopicHealth& topic) {
  return std::uint64_t{topic.requested_deadline_missed()} + topic.offered_deadline_missed();
}

std::uint64_t deadline_misses(const Health& health) {
  std::uint64_t misses = 0;
  for (const TopicHealth& t : health.topics()) misses += deadline_misses(t);
  return misses;
}

void log_bad_input(const std::string& service, std::uint64_t count, const std::string& message) {
  // The log names every problem; a flood of bad frames is thinned to every 100th.
  if (count <= kLoggedErrors || count % 100 == 0)
    std::cerr << service << ": bad input #" << count << ": " << message << std::endl;
}

HealthReporter::HealthReporter(transport::Participant& participant, std::string service,
                               CountersSource counters, std::chrono::milliseconds period)
    : writer_(participant, transport::topics::kHealth, transport::state_topic_qos()),
      service_(std::move(service)),
      counters_(std::move(counters)),
      period_(period) {}

void HealthReporter::set_state(HealthState state, const std::string& message) {
  if (state == HEALTH_STOPPING) systemd_.stopping();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = state;
    message_ = message;
  }
  publish_now();
  // The last word of a stopping service (its final counters) must reach the readers before the
  // process exits and takes its writer with it.
  if (state == HEALTH_STOPPING) writer_.wait_for_acknowledgments(kStoppingAckWait);
}

void HealthReporter::set_message(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    message_ = message;
  }
  publish_now();
}

void HealthReporter::frame_processed() {
  bool recovered = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++frames_;
    ++good_since_error_;
    if (state_ == HEALTH_STARTING) {
      state_ = HEALTH_OK;
      message_ = "processing";  // the start-up message ("waiting for ...") no longer holds
      recovered = true;
    } else if (state_ == HEALTH_DEGRADED && good_since_error_ >= kRecoverAfterFrames) {
      state_ = HEALTH_OK;
      recovered = true;
    }
  }
  if (recovered) publish_now();
}

void HealthReporter::bad_input(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++errors_;
    log_bad_input(service_, errors_, message);
    good_since_error_ = 0;
    message_ = message;
    if (state_ != HEALTH_FAILED && state_ != HEALTH_STOPPING) state_ = HEALTH_DEGRADED;
  }
  publish_now();
}

void HealthReporter::tick() {
  systemd_.ready(service_);
  systemd_.watchdog();
  const auto since = std::chrono::steady_clock::now() - last_publish_;
  // A reader of the health then knows when a miss happened (the supervisor lays them beside
  // the machine's stalls), not only that one did within the period.
  const bool missed = counters_ && since >= kMissPublishInterval &&
                      misses_of(counters_()) != published_misses_.load();
  if (missed || since >= period_) publish_now();
}

void HealthReporter::publish_now() {
  Health health;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    health.service(service_);
    health.state(state_);
    health.frames_processed(frames_);
    health.errors(errors_);
    health.message(clip(message_, MAX_HEALTH_MESSAGE_LENGTH));
  }
  health.time_ns(transport::now_ns());
  if (counters_) {
    const auto counters = counters_();
    published_misses_ = misses_of(counters);
    for (const auto& c : counters) {
      if (health.topics().size() >= MAX_HEALTH_TOPICS) break;
      TopicHealth topic;
      topic.topic(clip(c.topic, MAX_TOPIC_NAME_LENGTH));
      topic.samples(c.samples);
      topic.requested_deadline_missed(c.requested_deadline_missed);
      topic.offered_deadline_missed(c.offered_deadline_missed);
      health.topics().push_back(topic);
    }
  }
  writer_.write(health);
  last_publish_ = std::chrono::steady_clock::now();
}

std::uint64_t HealthReporter::frames_processed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return frames_;
}

std::uint32_t HealthReporter::errors() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return errors_;
}

}  // namespace thermovis::node
