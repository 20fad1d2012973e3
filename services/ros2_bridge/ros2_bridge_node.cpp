#include "ros2_bridge_node.hpp"

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/ros2_bridge/ros2_messages.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::ros2_bridge {

namespace topics = transport::topics;

namespace {

// The fused frames as thermovis-view reads them: an observer's (the bridge is not in the chain
// whose rate the services watch).
transport::TopicQos fused_reader_qos() {
  return transport::observer_qos(transport::frame_topic_qos());
}

bool subscribed(const transport::WriterBase& writer) { return writer.counters().matched > 0; }

// Publishes each sample taken from `in` on `out` in its ROS 2 form (counted in `published`), or
// drops it (counted in `unsubscribed`) while `out` has no ROS reader.
template <class T, class Ros>
void forward(transport::Reader<T>& in, transport::Writer<Ros>& out, const std::string& frame_id,
             std::uint64_t& published, std::uint64_t& unsubscribed) {
  auto samples = in.take();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (!subscribed(out)) {
      ++unsubscribed;
      continue;
    }
    out.write(to_ros(samples[i], frame_id));
    ++published;
  }
}

}  // namespace

Ros2BridgeNode::Ros2BridgeNode(transport::Participant& pipeline, transport::Participant& ros,
                               const Ros2BridgeConfig& config, const std::string& service_name)
    : config_(config),
      fused_in_(pipeline, topics::kFused, fused_reader_qos(),
                node::count_bad_input(stats_.bad, health_)),
      ranges_in_(pipeline, topics::kRanges, transport::event_topic_qos()),
      detections_in_(pipeline, topics::kDetections, transport::event_topic_qos()),
      obstacles_in_(pipeline, topics::kObstacles, transport::event_topic_qos()),
      image_out_(ros, topics::kRos2FusedImage, transport::event_topic_qos(config.image_depth)),
      ranges_out_(ros, topics::kRos2Ranges, transport::event_topic_qos(config.event_depth)),
      detections_out_(ros, topics::kRos2Detections, transport::event_topic_qos(config.event_depth)),
      obstacles_out_(ros, topics::kRos2Obstacles, transport::event_topic_qos(config.event_depth)),
      health_(pipeline, service_name, [this] {
        return std::vector<transport::TopicCountersSnapshot>{
            fused_in_.counters(),       ranges_in_.counters(),    detections_in_.counters(),
            obstacles_in_.counters(),   image_out_.counters(),    ranges_out_.counters(),
            detections_out_.counters(), obstacles_out_.counters()};
      }) {
  health_.set_state(HEALTH_STARTING, "waiting for ROS 2 subscribers and pipeline data");
}

void Ros2BridgeNode::run() {
  while (!node::stop_requested()) {
    health_.tick();
    // Fused frames come first, their ranges some milliseconds later: a short wait keeps the
    // ranges' extra delay below it.
    fused_in_.wait_for_data(std::chrono::milliseconds(10));
    forward_fused();
    forward_ranges();
    forward_detections();
    forward_obstacles();
  }
  health_.set_state(HEALTH_STOPPING, "published " + std::to_string(stats_.images) + " images, " +
                                         std::to_string(stats_.ranges) + " range arrays");
}

void Ros2BridgeNode::forward_fused() {
  auto frames = fused_in_.take();
  if (frames.empty()) return;
  if (!subscribed(image_out_)) {
    stats_.unsubscribed += frames.size();
    return;
  }
  // Only the newest frame: an older one still queued is already late for a live view.
  const std::size_t newest = frames.size() - 1;
  stats_.unsubscribed += newest;
  try {
    to_ros_image(frames[newest], config_.image_frame_id, image_);
  } catch (const node::FrameError& e) {
    ++stats_.bad;
    health_.bad_input(std::string(topics::kFused) + ": " + e.what());
    return;
  }
  if (!frames.still_valid(newest)) {
    ++stats_.overwritten;
    return;
  }
  image_out_.write(image_);
  ++stats_.images;
  health_.frame_processed();
}

void Ros2BridgeNode::forward_ranges() {
  forward(ranges_in_, ranges_out_, config_.ranges_frame_id, stats_.ranges, stats_.unsubscribed);
}

void Ros2BridgeNode::forward_detections() {
  forward(detections_in_, detections_out_, config_.image_frame_id, stats_.detections,
          stats_.unsubscribed);
}

void Ros2BridgeNode::forward_obstacles() {
  forward(obstacles_in_, obstacles_out_, config_.ranges_frame_id, stats_.obstacles,
          stats_.unsubscribed);
}

}  // namespace thermovis::ros2_bridge
