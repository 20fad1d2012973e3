#pragma once
// The ROS 2 wire types (idl/ros2/, library thermovis::ros2_idl) for the typed transport::Writer.
#include "ros2/sensor_msgsPubSubTypes.h"
#include "ros2/thermovis_msgsPubSubTypes.h"
#include "thermovis/transport/topic_types.hpp"

namespace thermovis::transport {

template <>
struct TypeSupportOf<::sensor_msgs::msg::dds_::Image_> {
  using type = ::sensor_msgs::msg::dds_::Image_PubSubType;
};
template <>
struct TypeSupportOf<::thermovis_msgs::msg::dds_::RangeArray_> {
  using type = ::thermovis_msgs::msg::dds_::RangeArray_PubSubType;
};
template <>
struct TypeSupportOf<::thermovis_msgs::msg::dds_::DetectionArray_> {
  using type = ::thermovis_msgs::msg::dds_::DetectionArray_PubSubType;
};

template <>
struct TypeSupportOf<::thermovis_msgs::msg::dds_::ObstacleArray_> {
  using type = ::thermovis_msgs::msg::dds_::ObstacleArray_PubSubType;
};

}  // namespace thermovis::transport
