#pragma once
// thermovis-ros2: republishes the pipeline for ROS 2 on a participant of its own (UDP by
// default): the left eye of thermovis/fused as sensor_msgs/Image on rt/thermovis/fused/image,
// thermovis/ranges, thermovis/detections and thermovis/obstacles as thermovis_msgs arrays
// (idl/ros2/), QoS as a ROS 2
// publisher's default (RELIABLE, VOLATILE, KEEP_LAST), which ROS 2's reliable and best-effort
// ("sensor data") subscriptions both match.
//
// A topic is converted only while a reader is matched on its ROS side: otherwise its input
// samples are taken and dropped (no copy, no conversion, nothing written), so an unwatched
// bridge costs the pipeline next to nothing. A fused frame whose header is corrupt is reported
// (log and health) and skipped.
#include <cstdint>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/node/health.hpp"
#include "thermovis/perception.h"
#include "thermovis/ros2_bridge/ros2_messages.hpp"
#include "thermovis/ros2_bridge/ros2_types.hpp"
#include "thermovis/transport/frames.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::ros2_bridge {

struct Ros2BridgeConfig {
  // ROS frame ids: the fused image is on the rectified left grid; ranges' positions are in the
  // left visible camera's optical frame (x right, y down, z forward), boxes on the grid.
  std::string image_frame_id = kImageFrameId;
  std::string ranges_frame_id = kRangesFrameId;
  std::int32_t image_depth = 2;   // KEEP_LAST of the image writer (each sample is a whole image)
  std::int32_t event_depth = 10;  // ranges and detections: rclcpp's default depth
};

struct Ros2BridgeStats {
  std::uint64_t images = 0;        // images converted and published
  std::uint64_t ranges = 0;        // range arrays converted and published
  std::uint64_t detections = 0;    // detection arrays converted and published
  std::uint64_t obstacles = 0;     // obstacle arrays converted and published
  std::uint64_t unsubscribed = 0;  // input samples dropped because no ROS reader was matched
  std::uint64_t overwritten = 0;   // fused frames reused by their writer while copied (dropped)
  std::uint64_t bad = 0;           // corrupt inputs
};

class Ros2BridgeNode {
 public:
  // `pipeline`: the pipeline's participant (frames by data-sharing); `ros`: the participant the
  // ROS 2 topics are published on. Both may be the same.
  Ros2BridgeNode(transport::Participant& pipeline, transport::Participant& ros,
                 const Ros2BridgeConfig& config, const std::string& service_name);
  void run();  // until node::stop_requested()
  const Ros2BridgeStats& stats() const { return stats_; }

 private:
  void forward_fused();
  void forward_ranges();
  void forward_detections();
  void forward_obstacles();

  Ros2BridgeConfig config_;
  transport::FrameReader<GridStereoFrame> fused_in_;  // or its packed twin (--frame-transport)
  transport::Reader<RangeArray> ranges_in_;
  transport::Reader<DetectionArray> detections_in_;
  transport::Reader<ObstacleArray> obstacles_in_;
  transport::Writer<sensor_msgs::msg::dds_::Image_> image_out_;
  transport::Writer<thermovis_msgs::msg::dds_::RangeArray_> ranges_out_;
  transport::Writer<thermovis_msgs::msg::dds_::DetectionArray_> detections_out_;
  transport::Writer<thermovis_msgs::msg::dds_::ObstacleArray_> obstacles_out_;
  node::HealthReporter health_;
  sensor_msgs::msg::dds_::Image_ image_;  // reused: its data buffer keeps its size
  Ros2BridgeStats stats_;
};

}  // namespace thermovis::ros2_bridge
