#include "ros2_bag.hpp"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <limits>
#include <stdexcept>
#include <system_error>

namespace thermovis::cli {

namespace fs = std::filesystem;

namespace {

// rmw_qos_*_policy_t values as rosbag2 writes them before metadata version 9.
constexpr int kReliable = 1, kBestEffort = 2;
constexpr int kTransientLocal = 1, kVolatile = 2;
constexpr int kHistoryUnknown = 3;
constexpr int kLivelinessAutomatic = 1;

// rmw_time_t {sec, nsec}; RMW_DURATION_INFINITE for 0 (unset).
YAML::Node rmw_time(std::chrono::nanoseconds duration) {
  std::int64_t ns = duration.count();
  if (ns <= 0) ns = std::numeric_limits<std::int64_t>::max();
  YAML::Node node;
  node["sec"] = static_cast<std::uint64_t>(ns / 1'000'000'000);
  node["nsec"] = static_cast<std::uint64_t>(ns % 1'000'000'000);
  return node;
}

YAML::Node nanoseconds(std::uint64_t ns) {
  YAML::Node node;
  node["nanoseconds"] = ns;
  return node;
}

YAML::Node since_epoch(std::uint64_t ns) {
  YAML::Node node;
  node["nanoseconds_since_epoch"] = ns;
  return node;
}

}  // namespace

fs::path create_ros2_bag_folder(const fs::path& dir) {
  const std::string name = "ROS 2 bag folder '" + dir.string() + "'";
  std::error_code error;
  if (fs::exists(dir, error)) {
    if (!fs::is_directory(dir, error)) throw std::runtime_error(name + " is a file, not a folder");
    if (!fs::is_empty(dir, error))
      throw std::runtime_error(name +
                               " exists and is not empty: a bag is written into a new or "
                               "empty folder");
  } else if (fs::create_directories(dir, error), error || !fs::is_directory(dir)) {
    throw std::runtime_error(name + " cannot be created: " + error.message());
  }
  // rosbag2 names the file after the folder: DIR/<name>_0.mcap.
  fs::path folder = fs::absolute(dir).lexically_normal();
  if (folder.filename().empty()) folder = folder.parent_path();  // "bag/" -> "bag"
  return dir / (folder.filename().string() + "_0.mcap");
}

std::string offered_qos_profiles(const transport::TopicQos& qos) {
  YAML::Node profile;
  profile["history"] = kHistoryUnknown;
  profile["depth"] = 0;
  // Frames are BEST_EFFORT (as the bridge writes them), the other kinds RELIABLE; state topics
  // keep their latest sample for late readers.
  profile["reliability"] = qos.kind == transport::TopicKind::frame ? kBestEffort : kReliable;
  profile["durability"] = qos.kind == transport::TopicKind::state ? kTransientLocal : kVolatile;
  profile["deadline"] = rmw_time(qos.deadline);
  profile["lifespan"] = rmw_time({});
  profile["liveliness"] = kLivelinessAutomatic;
  profile["liveliness_lease_duration"] = rmw_time({});
  profile["avoid_ros_namespace_conventions"] = false;
  YAML::Node profiles(YAML::NodeType::Sequence);
  profiles.push_back(profile);
  return YAML::Dump(profiles);
}

std::string ros2_bag_metadata(const std::string& mcap_name, const record::McapStatistics& stats,
                              const std::vector<Ros2BagTopicCount>& topics) {
  const std::uint64_t start = stats.message_start_time;
  const std::uint64_t duration =
      stats.message_end_time > start ? stats.message_end_time - start : 0;
  YAML::Node info;
  info["version"] = 5;
  info["storage_identifier"] = "mcap";
  info["duration"] = nanoseconds(duration);
  info["starting_time"] = since_epoch(start);
  info["message_count"] = stats.message_count;
  YAML::Node with_counts(YAML::NodeType::Sequence);
  for (const Ros2BagTopicCount& topic : topics) {
    YAML::Node metadata;
    metadata["name"] = topic.name;
    metadata["type"] = topic.type;
    metadata["serialization_format"] = "cdr";
    metadata["offered_qos_profiles"] = topic.offered_qos_profiles;
    YAML::Node entry;
    entry["topic_metadata"] = metadata;
    entry["message_count"] = topic.message_count;
    with_counts.push_back(entry);
  }
  info["topics_with_message_count"] = with_counts;
  info["compression_format"] = "";
  info["compression_mode"] = "";
  YAML::Node paths(YAML::NodeType::Sequence);
  paths.push_back(mcap_name);
  info["relative_file_paths"] = paths;
  YAML::Node file;
  file["path"] = mcap_name;
  file["starting_time"] = since_epoch(start);
  file["duration"] = nanoseconds(duration);
  file["message_count"] = stats.message_count;
  YAML::Node files(YAML::NodeType::Sequence);
  files.push_back(file);
  info["files"] = files;
  YAML::Node root;
  root["rosbag2_bagfile_information"] = info;
  return YAML::Dump(root) + "\n";
}

void write_ros2_bag_metadata(const fs::path& mcap_file, const record::McapStatistics& stats,
                             const std::vector<Ros2BagTopicCount>& topics) {
  const fs::path path = mcap_file.parent_path() / "metadata.yaml";
  std::ofstream out(path);
  out << ros2_bag_metadata(mcap_file.filename().string(), stats, topics);
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace thermovis::cli
