#pragma once
// A ROS 2 bag folder as rosbag2 writes one with its MCAP storage, so that `ros2 bag play DIR`
// (and `ros2 bag info`) take it: DIR/<folder name>_0.mcap (ros2msg schemas, cdr messages, the
// offered QoS in each channel's metadata) and DIR/metadata.yaml (rosbag2_bagfile_information,
// version 5 as rosbag2 on Humble writes it; Iron and later read it too).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "thermovis/record/mcap.hpp"
#include "thermovis/transport/qos.hpp"

namespace thermovis::cli {

// The MCAP Header profile of a ROS 2 bag.
inline constexpr const char* kRos2Profile = "ros2";

// Makes `dir` ready for a bag before anything is recorded: it must be a new path or an empty
// folder (rosbag2 never adds to a bag). Returns the path of the bag's MCAP file in it. Throws
// std::runtime_error naming `dir` when it is a file, a folder that is not empty, or cannot be
// created.
std::filesystem::path create_ros2_bag_folder(const std::filesystem::path& dir);

// The "offered_qos_profiles" metadata of a channel: rosbag2's YAML list of the offers it saw, here
// one publisher offering `qos` (reliability and durability of its kind; DEADLINE, lifespan and
// liveliness lease infinite unless set; history unknown and depth 0, as a discovered offer has).
std::string offered_qos_profiles(const transport::TopicQos& qos);

struct Ros2BagTopicCount {
  std::string name;                  // e.g. "/thermovis/ranges"
  std::string type;                  // e.g. "thermovis_msgs/msg/RangeArray"
  std::string offered_qos_profiles;  // as in the channel's metadata
  std::uint64_t message_count = 0;
};

// The text of metadata.yaml for a bag of one MCAP file `mcap_name` (relative to the folder) whose
// statistics are `stats`, holding `topics`.
std::string ros2_bag_metadata(const std::string& mcap_name, const record::McapStatistics& stats,
                              const std::vector<Ros2BagTopicCount>& topics);

// Writes metadata.yaml into the bag folder of `mcap_file`. Throws std::runtime_error naming the
// file when it cannot be written.
void write_ros2_bag_metadata(const std::filesystem::path& mcap_file,
                             const record::McapStatistics& stats,
                             const std::vector<Ros2BagTopicCount>& topics);

}  // namespace thermovis::cli
