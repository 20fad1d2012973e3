#pragma once
// The QoS of thermovis topics: one place for history depths, pool sizes, reliability,
// durability and deadlines, so every service gets the same settings for the same topic.
#include <chrono>
#include <cstdint>

#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

namespace thermovis::transport {

enum class TopicKind {
  frame,  // plain image frames: data-sharing with loans, KEEP_LAST 2-4, pools sized exactly
  // a frame topic's packed twin (PackedStereoFrame, frames.hpp): serialised, KEEP_LAST 2-4,
  // payloads allocated to each sample's size and reused
  packed_frame,
  event,  // small per-frame messages (detections, ranges, timing): RELIABLE, VOLATILE
  state,  // latest state per key (health): RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1
};

struct TopicQos {
  TopicKind kind = TopicKind::event;
  // KEEP_LAST depth (per instance). Frames: 2..4; the pools hold exactly this many samples
  // (allocated_samples = max_samples = depth), the Fast DDS defaults would preallocate about
  // 100 samples per reader (620 MB for a 6.2 MB frame).
  std::int32_t depth = 8;
  // Readers expected on a frame topic: each may hold one loaned sample while the writer fills
  // the next, so the writer's pool gets extra_samples = max_readers + 1.
  std::int32_t max_readers = 2;
  // DEADLINE period: the longest gap between two samples before the writer's and readers'
  // listeners report a miss. Zero: no deadline.
  std::chrono::nanoseconds deadline{0};
};

// 50 Hz frames come every 20 ms. A DEADLINE period equal to that counts a miss on any jitter
// (measured: the bridge's own writer missed about once per sample with 20 ms, every capture
// on time). 30 ms, one and a half frame periods, is missed when a capture slot passes with no
// frame (a dropped capture) or a frame comes more than half a period behind its slot. Latency
// against the 20 ms budget is checked from the stamps, not by DEADLINE.
inline constexpr std::chrono::milliseconds kDefaultFrameDeadline{30};

TopicQos frame_topic_qos(std::chrono::nanoseconds deadline = kDefaultFrameDeadline,
                         std::int32_t depth = 2, std::int32_t max_readers = 2);
// The QoS of `frame_qos`'s packed twin: the same depth, readers and DEADLINE.
TopicQos packed_twin_qos(TopicQos frame_qos);
TopicQos event_topic_qos(std::int32_t depth = 8);
TopicQos state_topic_qos();
// The reader QoS of an observer of `qos`'s topic (recorder, viewer, ROS 2 bridge: not part of the
// pipeline): no DEADLINE requested, so it matches any writer's offer and its rate is not watched.
// Still RELIABLE: BEST_EFFORT data-sharing readers left a writer's pool stuck when killed (see
// kStalledPoolRecovery).
TopicQos observer_qos(TopicQos qos);

// Throws std::invalid_argument naming the bad field (depth out of range, negative deadline...).
void validate(const TopicQos& qos);

eprosima::fastdds::dds::DataWriterQos writer_qos(const TopicQos& qos);
eprosima::fastdds::dds::DataReaderQos reader_qos(const TopicQos& qos);

}  // namespace thermovis::transport
