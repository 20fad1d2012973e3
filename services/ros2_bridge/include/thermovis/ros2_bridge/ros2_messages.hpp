#pragma once
// thermovis messages -> their ROS 2 counterparts (idl/ros2/): the fused frame's left eye as a
// sensor_msgs/Image, ranges, detections and obstacles as thermovis_msgs arrays, and the ROS 2 names
// and .msg definitions of those types. Pure conversions, testable without DDS; the bridge
// (thermovis-ros2) publishes them, `thermovis record --ros2` writes them into a ROS 2 bag.
#include <cstdint>
#include <string>

#include "ros2/sensor_msgs.h"
#include "ros2/thermovis_msgs.h"
#include "thermovis/frames.h"
#include "thermovis/obstacles.h"
#include "thermovis/perception.h"

namespace thermovis::ros2_bridge {

// header.frame_id of the image and the detections (on the rectified left grid) and of the ranges
// (positions in the left visible camera's optical frame: x right, y down, z forward).
inline constexpr const char* kImageFrameId = "thermovis_rectified_left";
inline constexpr const char* kRangesFrameId = "thermovis_visible_left_optical";

// The ROS 2 name of a DDS topic: "rt/thermovis/ranges" -> "/thermovis/ranges" (ROS 2 puts "rt"
// before its topics on DDS). std::invalid_argument naming it for a topic without that prefix.
std::string ros2_topic_name(const std::string& dds_topic);

// The ROS 2 name of a DDS type as rosidl generates it: "sensor_msgs::msg::dds_::Image_" ->
// "sensor_msgs/msg/Image". std::invalid_argument naming it for another form.
std::string ros2_type_name(const std::string& dds_type);

// The .msg text of a ROS 2 type whose definition is built in (idl/ros2: sensor_msgs/msg/Image and
// what it uses, the thermovis_msgs package), e.g. "thermovis_msgs/msg/RangeArray".
// std::invalid_argument listing the known types for another one.
const std::string& ros2_msg_text(const std::string& ros2_type);
// The complete definition of such a type as a ROS 2 bag's MCAP schema (encoding "ros2msg",
// record/ros2msg.hpp): its .msg text and those of the types it uses.
std::string ros2msg_definition(const std::string& ros2_type);

// ROS 2 time of a stamp in ns since the Unix epoch (nanosec always in 0..999999999).
builtin_interfaces::msg::dds_::Time_ to_ros_time(std::int64_t ns);

// The sensor_msgs/image_encodings name of a pixel format ("mono8", "bgr8", "mono16");
// node::FrameError for PIXEL_FORMAT_UNKNOWN or a value that is none of them.
std::string ros_encoding(PixelFormat format);

// The left eye of `frame` into `image` (its data buffer is reused: no allocation once it has
// grown to the frame size): header.stamp = capture time, header.frame_id = `frame_id`, width,
// height, encoding, step (rows packed), is_bigendian 0. node::FrameError naming the frame when
// its header is corrupt (unknown pixel format, size beyond the array, step not the packed row).
void to_ros_image(const GridStereoFrame& frame, const std::string& frame_id,
                  sensor_msgs::msg::dds_::Image_& image);

thermovis_msgs::msg::dds_::RangeArray_ to_ros(const RangeArray& ranges,
                                              const std::string& frame_id);
thermovis_msgs::msg::dds_::DetectionArray_ to_ros(const DetectionArray& detections,
                                                  const std::string& frame_id);
thermovis_msgs::msg::dds_::ObstacleArray_ to_ros(const ObstacleArray& obstacles,
                                                 const std::string& frame_id);

}  // namespace thermovis::ros2_bridge
