#pragma once
// thermovis messages -> their ROS 2 counterparts (idl/ros2/): the fused frame's left eye as a
// sensor_msgs/Image, ranges and detections as thermovis_msgs arrays. Pure conversions, testable
// without DDS.
#include <cstdint>
#include <string>

#include "ros2/sensor_msgs.h"
#include "ros2/thermovis_msgs.h"
#include "thermovis/frames.h"
#include "thermovis/perception.h"

namespace thermovis::ros2_bridge {

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

}  // namespace thermovis::ros2_bridge
