#pragma once
// Per-topic counters of one writer or reader, updated by the DDS listener threads and read by
// the service (for its health message).
#include <atomic>
#include <cstdint>
#include <string>

namespace thermovis::transport {

struct TopicCountersSnapshot {
  std::string topic;
  std::uint64_t samples = 0;                    // written (writer) or taken (reader)
  std::uint32_t offered_deadline_missed = 0;    // writer: DEADLINE periods without a write
  std::uint32_t requested_deadline_missed = 0;  // reader: DEADLINE periods without a sample
  std::uint32_t matched = 0;                    // endpoints currently matched
};

struct TopicCounters {
  std::atomic<std::uint64_t> samples{0};
  std::atomic<std::uint32_t> offered_deadline_missed{0};
  std::atomic<std::uint32_t> requested_deadline_missed{0};
  std::atomic<std::uint32_t> matched{0};

  TopicCountersSnapshot snapshot(const std::string& topic) const {
    return {topic, samples.load(), offered_deadline_missed.load(), requested_deadline_missed.load(),
            matched.load()};
  }
};

}  // namespace thermovis::transport
