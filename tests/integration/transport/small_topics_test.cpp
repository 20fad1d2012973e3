// Small topics in one process (two participants on a private domain, loopback profile):
// health state reaches a late subscriber (TRANSIENT_LOCAL, one instance per service), ranges
// arrive reliably and in order, a DEADLINE miss is published when it is counted, and misuse is
// refused with a clear error.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <map>
#include <thread>

#include "thermovis/node/health.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

namespace tt = thermovis::transport;
using namespace std::chrono_literals;

tt::ParticipantConfig loopback(const std::string& name) {
  return {thermovis::test::private_domain(), {}, tt::kLoopbackProfile, name};
}

thermovis::Health health(const std::string& service, thermovis::HealthState state,
                         std::uint64_t frames) {
  thermovis::Health h;
  h.service(service);
  h.state(state);
  h.frames_processed(frames);
  h.message(state == thermovis::HEALTH_OK ? "running" : "starting");
  return h;
}

TEST(TransportSmallTopics, LateSubscriberGetsLastHealthOfEachService) {
  tt::Participant publisher(loopback("health writer"));
  tt::Writer<thermovis::Health> writer(publisher, tt::topics::kHealth, tt::state_topic_qos());
  writer.write(health("thermovis-detect", thermovis::HEALTH_STARTING, 0));
  writer.write(health("thermovis-detect", thermovis::HEALTH_OK, 50));
  writer.write(health("thermovis-range", thermovis::HEALTH_OK, 7));

  // Created after the writes: only durability can bring them.
  tt::Participant subscriber(loopback("health reader"));
  tt::Reader<thermovis::Health> reader(subscriber, tt::topics::kHealth, tt::state_topic_qos());
  ASSERT_TRUE(reader.wait_for_writers(1, 10s));
  std::map<std::string, std::uint64_t> frames_by_service;
  const auto give_up = std::chrono::steady_clock::now() + 10s;
  while (frames_by_service.size() < 2 && std::chrono::steady_clock::now() < give_up) {
    if (!reader.wait_for_data(100ms)) continue;
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      frames_by_service[samples[i].service().to_string()] = samples[i].frames_processed();
      EXPECT_EQ(samples[i].state(), thermovis::HEALTH_OK);  // the older state was replaced
    }
  }
  EXPECT_EQ(frames_by_service, (std::map<std::string, std::uint64_t>{{"thermovis-detect", 50},
                                                                     {"thermovis-range", 7}}));
}

// The supervisor lays each DEADLINE miss beside the machine's stalls by the time of the health
// that first counts it: a miss is published at the service's next tick, not a period later.
TEST(TransportSmallTopics, HealthIsPublishedWhenADeadlineMissIsCounted) {
  tt::Participant publisher(loopback("health writer"));
  tt::Participant subscriber(loopback("health reader"));
  tt::Reader<thermovis::Health> reader(subscriber, tt::topics::kHealth, tt::state_topic_qos());
  std::atomic<std::uint32_t> missed{0};
  thermovis::node::HealthReporter health(
      publisher, "thermovis-test",
      [&] {
        tt::TopicCountersSnapshot c;
        c.topic = "thermovis/frames/visible";
        c.requested_deadline_missed = missed.load();
        return std::vector<tt::TopicCountersSnapshot>{c};
      },
      std::chrono::hours(1));
  ASSERT_TRUE(reader.wait_for_writers(1, 10s));
  health.set_state(thermovis::HEALTH_OK, "processing");
  // Samples seen by `until`, ticking the reporter every few ms as a service's loop does.
  const auto take_while_ticking = [&](std::chrono::milliseconds span) {
    std::vector<thermovis::Health> seen;
    const auto until = std::chrono::steady_clock::now() + span;
    while (std::chrono::steady_clock::now() < until) {
      health.tick();
      if (!reader.wait_for_data(5ms)) continue;
      auto samples = reader.take();
      for (std::size_t i = 0; i < samples.size(); ++i) seen.push_back(samples[i]);
    }
    return seen;
  };
  const auto first = take_while_ticking(1000ms);
  ASSERT_FALSE(first.empty());
  EXPECT_EQ(thermovis::node::deadline_misses(first.back()), 0u);
  // No miss, a period of an hour: ticking publishes nothing.
  EXPECT_TRUE(take_while_ticking(200ms).empty());
  missed = 2;
  const std::int64_t counted_ns = tt::now_ns();
  const auto after = take_while_ticking(1000ms);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(thermovis::node::deadline_misses(after.front()), 2u);
  EXPECT_GE(after.front().time_ns(), counted_ns);
  EXPECT_LT(after.front().time_ns(), counted_ns + 1'000'000'000);
}

TEST(TransportSmallTopics, RangesArriveInOrder) {
  tt::Participant a(loopback("ranges writer"));
  tt::Participant b(loopback("ranges reader"));
  tt::Reader<thermovis::RangeArray> reader(b, tt::topics::kRanges, tt::event_topic_qos());
  tt::Writer<thermovis::RangeArray> writer(a, tt::topics::kRanges, tt::event_topic_qos());
  ASSERT_TRUE(writer.wait_for_readers(1, 10s));
  ASSERT_TRUE(reader.wait_for_writers(1, 10s));
  for (std::uint64_t seq = 1; seq <= 5; ++seq) {
    thermovis::RangeArray ranges;
    ranges.frame_seq(seq);
    ranges.targets().resize(seq);
    ranges.targets().back().distance_m(2.5f * static_cast<float>(seq));
    writer.write(ranges);
  }
  std::vector<std::uint64_t> seqs;
  const auto give_up = std::chrono::steady_clock::now() + 10s;
  while (seqs.size() < 5 && std::chrono::steady_clock::now() < give_up) {
    if (!reader.wait_for_data(100ms)) continue;
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      seqs.push_back(samples[i].frame_seq());
      EXPECT_EQ(samples[i].targets().size(), samples[i].frame_seq());
      EXPECT_FLOAT_EQ(samples[i].targets().back().distance_m(),
                      2.5f * static_cast<float>(samples[i].frame_seq()));
    }
  }
  EXPECT_EQ(seqs, (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(writer.counters().samples, 5u);
  EXPECT_EQ(reader.counters().samples, 5u);
}

TEST(TransportSmallTopics, MisuseIsRefused) {
  tt::Participant participant(loopback("misuse"));
  // A type with sequences cannot be a frame topic (no data-sharing) ...
  EXPECT_THROW(
      tt::Writer<thermovis::RangeArray>(participant, "thermovis/test/bad", tt::frame_topic_qos()),
      std::invalid_argument);
  // ... nor be loaned.
  tt::Writer<thermovis::RangeArray> writer(participant, tt::topics::kRanges, tt::event_topic_qos());
  EXPECT_THROW(writer.loan(), std::runtime_error);
  // One topic name, one type.
  EXPECT_THROW(
      tt::Writer<thermovis::Health>(participant, tt::topics::kRanges, tt::event_topic_qos()),
      std::runtime_error);
}

}  // namespace
