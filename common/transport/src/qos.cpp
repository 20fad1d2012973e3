#include "thermovis/transport/qos.hpp"

#include <stdexcept>
#include <string>

namespace thermovis::transport {

namespace dds = eprosima::fastdds::dds;

TopicQos frame_topic_qos(std::chrono::nanoseconds deadline, std::int32_t depth,
                         std::int32_t max_readers) {
  return {TopicKind::frame, depth, max_readers, deadline};
}

TopicQos packed_twin_qos(TopicQos frame_qos) {
  frame_qos.kind = TopicKind::packed_frame;
  return frame_qos;
}

TopicQos event_topic_qos(std::int32_t depth) { return {TopicKind::event, depth, 0, {}}; }

TopicQos state_topic_qos() { return {TopicKind::state, 1, 0, {}}; }

TopicQos observer_qos(TopicQos qos) {
  qos.deadline = std::chrono::nanoseconds(0);
  return qos;
}

void validate(const TopicQos& qos) {
  const bool frames = qos.kind == TopicKind::frame || qos.kind == TopicKind::packed_frame;
  if (frames && (qos.depth < 2 || qos.depth > 4)) {
    throw std::invalid_argument("frame topic history depth " + std::to_string(qos.depth) +
                                " out of range 2..4 (each slot is a full frame)");
  }
  if (qos.depth < 1 || qos.depth > 1000) {
    throw std::invalid_argument("topic history depth " + std::to_string(qos.depth) +
                                " out of range 1..1000");
  }
  if (frames && (qos.max_readers < 1 || qos.max_readers > 16)) {
    throw std::invalid_argument("frame topic max_readers " + std::to_string(qos.max_readers) +
                                " out of range 1..16");
  }
  if (qos.deadline.count() < 0) {
    throw std::invalid_argument("topic deadline must not be negative");
  }
}

namespace {

eprosima::fastrtps::Duration_t to_duration(std::chrono::nanoseconds period) {
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(period);
  return eprosima::fastrtps::Duration_t(static_cast<std::int32_t>(seconds.count()),
                                        static_cast<std::uint32_t>((period - seconds).count()));
}

// The settings writers and readers share (both QoS classes have the same policy accessors).
template <class Qos>
void apply_common(const TopicQos& qos, Qos& out) {
  validate(qos);
  out.reliability().kind = dds::RELIABLE_RELIABILITY_QOS;
  out.history().kind = dds::KEEP_LAST_HISTORY_QOS;
  out.history().depth = qos.depth;
  out.durability().kind = qos.kind == TopicKind::state ? dds::TRANSIENT_LOCAL_DURABILITY_QOS
                                                       : dds::VOLATILE_DURABILITY_QOS;
  if (qos.deadline.count() > 0) out.deadline().period = to_duration(qos.deadline);
  if (qos.kind == TopicKind::frame) {
    // One instance (no keys); the pool holds exactly `depth` samples.
    out.resource_limits().max_instances = 1;
    out.resource_limits().max_samples_per_instance = qos.depth;
    out.resource_limits().max_samples = qos.depth;
    out.resource_limits().allocated_samples = qos.depth;
    // AUTOMATIC: data-sharing with every reader on this host (the frames' path); a remote
    // reader would still get serialised samples over the network.
    out.data_sharing().automatic();
  } else if (qos.kind == TopicKind::packed_frame) {
    // Serialised samples of up to 13 MB whose size follows the image: no data-sharing (the
    // type is not plain), at most `depth` samples, and payload buffers allocated to the
    // samples' size and reused (the preallocated default would reserve the bound per slot).
    out.resource_limits().max_instances = 1;
    out.resource_limits().max_samples_per_instance = qos.depth;
    out.resource_limits().max_samples = qos.depth;
    out.resource_limits().allocated_samples = qos.depth;
    out.data_sharing().off();
    out.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  } else {
    // Small types have strings and sequences: not plain, so they go by the transports.
    out.data_sharing().off();
  }
}

}  // namespace

dds::DataWriterQos writer_qos(const TopicQos& qos) {
  dds::DataWriterQos out = dds::DATAWRITER_QOS_DEFAULT;
  apply_common(qos, out);
  if (qos.kind == TopicKind::frame) {
    // Slots beyond the history: one per reader holding a loan plus the one being filled.
    out.resource_limits().extra_samples = qos.max_readers + 1;
  }
  return out;
}

dds::DataReaderQos reader_qos(const TopicQos& qos) {
  dds::DataReaderQos out = dds::DATAREADER_QOS_DEFAULT;
  apply_common(qos, out);
  if (qos.kind == TopicKind::frame) {
    out.resource_limits().extra_samples = 1;
    out.reader_resource_limits().max_samples_per_read = qos.depth;
  }
  return out;
}

}  // namespace thermovis::transport
