#include "thermovis/ros2_bridge/ros2_messages.hpp"

#include <cstring>
#include <map>
#include <stdexcept>

#include "ros2_msg_text.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/record/ros2msg.hpp"
#include "thermovis/transport/stamps.hpp"

namespace thermovis::ros2_bridge {

namespace msgs = thermovis_msgs::msg::dds_;

namespace {

std_msgs::msg::dds_::Header_ header(std::int64_t capture_ns, const std::string& frame_id) {
  std_msgs::msg::dds_::Header_ h;
  h.stamp_(to_ros_time(capture_ns));
  h.frame_id_(frame_id);
  return h;
}

msgs::Box2D_ to_ros(const Box2D& box) {
  msgs::Box2D_ b;
  b.x_(box.x());
  b.y_(box.y());
  b.width_(box.width());
  b.height_(box.height());
  return b;
}

}  // namespace

std::string ros2_topic_name(const std::string& dds_topic) {
  constexpr const char* kPrefix = "rt/";
  if (dds_topic.rfind(kPrefix, 0) != 0 || dds_topic.size() == 3)
    throw std::invalid_argument("DDS topic '" + dds_topic + "' is not a ROS 2 topic (rt/...)");
  return dds_topic.substr(2);
}

std::string ros2_type_name(const std::string& dds_type) {
  // <package>::msg::dds_::<Type>_
  const std::string middle = "::msg::dds_::";
  const auto at = dds_type.find(middle);
  const std::size_t name_start = at + middle.size();
  if (at == std::string::npos || at == 0 || dds_type.size() < name_start + 2 ||
      dds_type.back() != '_' || dds_type.find("::", name_start) != std::string::npos)
    throw std::invalid_argument("DDS type '" + dds_type +
                                "' is not a ROS 2 type (<package>::msg::dds_::<Type>_)");
  return dds_type.substr(0, at) + "/msg/" +
         dds_type.substr(name_start, dds_type.size() - name_start - 1);
}

const std::string& ros2_msg_text(const std::string& ros2_type) {
  const auto& files = ros2_msg_files();
  const auto it = files.find(ros2_type);
  if (it != files.end()) return it->second;
  std::string known;
  for (const auto& [name, text] : files) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("no built-in .msg definition of ROS 2 type '" + ros2_type +
                              "' (known: " + known + ")");
}

std::string ros2msg_definition(const std::string& ros2_type) {
  return record::ros2msg_schema(ros2_type,
                                [](const std::string& type) { return ros2_msg_text(type); });
}

builtin_interfaces::msg::dds_::Time_ to_ros_time(std::int64_t ns) {
  constexpr std::int64_t kPerSecond = 1'000'000'000;
  std::int64_t sec = ns / kPerSecond;
  std::int64_t rest = ns % kPerSecond;
  if (rest < 0) {  // floor for stamps before the epoch: nanosec stays non-negative
    --sec;
    rest += kPerSecond;
  }
  builtin_interfaces::msg::dds_::Time_ t;
  t.sec_(static_cast<std::int32_t>(sec));
  t.nanosec_(static_cast<std::uint32_t>(rest));
  return t;
}

std::string ros_encoding(PixelFormat format) {
  switch (format) {
    case PIXEL_FORMAT_MONO8:
      return "mono8";
    case PIXEL_FORMAT_BGR8:
      return "bgr8";
    case PIXEL_FORMAT_MONO16:
      return "mono16";
    default:
      throw node::FrameError("pixel format " + std::to_string(format) +
                             " has no ROS image encoding");
  }
}

void to_ros_image(const GridStereoFrame& frame, const std::string& frame_id,
                  sensor_msgs::msg::dds_::Image_& image) {
  // view() checks the header against the array (format, size, packed step) and names the frame.
  const cv::Mat left = node::view(frame, node::Eye::left);
  image.header_(header(frame.capture_time_ns(), frame_id));
  image.height_(static_cast<std::uint32_t>(left.rows));
  image.width_(static_cast<std::uint32_t>(left.cols));
  image.encoding_(ros_encoding(frame.pixel_format()));
  image.is_bigendian_(0);  // MONO16 pairs are little-endian (frames.idl)
  image.step_(static_cast<std::uint32_t>(left.step[0]));
  const std::size_t bytes = left.step[0] * static_cast<std::size_t>(left.rows);
  image.data_().resize(bytes);
  std::memcpy(image.data_().data(), left.data, bytes);
}

msgs::RangeArray_ to_ros(const RangeArray& ranges, const std::string& frame_id) {
  msgs::RangeArray_ out;
  out.header_(header(ranges.capture_time_ns(), frame_id));
  out.frame_seq_(ranges.frame_seq());
  out.targets_().reserve(ranges.targets().size());
  for (const TargetRange& r : ranges.targets()) {
    msgs::TargetRange_ t;
    t.target_id_(r.target_id());
    t.label_(r.label().to_string());
    t.distance_m_(r.distance_m());
    t.sigma_m_(r.sigma_m());
    t.x_m_(r.x_m());
    t.y_m_(r.y_m());
    t.z_m_(r.z_m());
    t.box_(to_ros(r.box()));
    t.point_count_(r.point_count());
    t.band_(static_cast<std::uint8_t>(r.band() <= BAND_FUSED ? r.band() : BAND_UNKNOWN));
    out.targets_().push_back(std::move(t));
  }
  out.latency_ms_(
      static_cast<float>(transport::latency_ms(ranges.stamps(), ranges.capture_time_ns())));
  return out;
}

msgs::DetectionArray_ to_ros(const DetectionArray& detections, const std::string& frame_id) {
  msgs::DetectionArray_ out;
  out.header_(header(detections.capture_time_ns(), frame_id));
  out.frame_seq_(detections.frame_seq());
  out.detections_().reserve(detections.detections().size());
  for (const Detection& d : detections.detections()) {
    msgs::Detection_ t;
    t.target_id_(d.target_id());
    t.label_(d.label().to_string());
    t.score_(d.score());
    t.box_(to_ros(d.box()));
    out.detections_().push_back(std::move(t));
  }
  return out;
}

msgs::ObstacleArray_ to_ros(const ObstacleArray& obstacles, const std::string& frame_id) {
  msgs::ObstacleArray_ out;
  out.header_(header(obstacles.capture_time_ns(), frame_id));
  out.frame_seq_(obstacles.frame_seq());
  const auto ground = [](GroundStatus g) {
    return static_cast<std::uint8_t>(g <= GROUND_NO_GROUND ? g : GROUND_NOT_SEARCHED);
  };
  out.visible_ground_(ground(obstacles.visible_ground()));
  out.infrared_ground_(ground(obstacles.infrared_ground()));
  out.ground_normal_(obstacles.ground_normal());
  out.ground_height_m_(obstacles.ground_height_m());
  out.obstacles_().reserve(obstacles.obstacles().size());
  for (const Obstacle& o : obstacles.obstacles()) {
    msgs::Obstacle_ t;
    t.obstacle_id_(o.obstacle_id());
    t.label_(o.label().to_string());
    t.has_target_(o.has_target());
    t.target_id_(o.target_id());
    t.distance_m_(o.distance_m());
    t.sigma_m_(o.sigma_m());
    t.x_m_(o.x_m());
    t.y_m_(o.y_m());
    t.z_m_(o.z_m());
    t.width_m_(o.width_m());
    t.height_m_(o.height_m());
    t.depth_m_(o.depth_m());
    t.box_(to_ros(o.box()));
    t.band_(static_cast<std::uint8_t>(o.band() <= BAND_FUSED ? o.band() : BAND_UNKNOWN));
    t.stixels_(o.stixels());
    out.obstacles_().push_back(std::move(t));
  }
  out.free_space_m_().assign(obstacles.free_space_m().begin(), obstacles.free_space_m().end());
  out.free_space_row_().assign(obstacles.free_space_row().begin(),
                               obstacles.free_space_row().end());
  out.max_distance_m_(obstacles.max_distance_m());
  out.latency_ms_(
      static_cast<float>(transport::latency_ms(obstacles.stamps(), obstacles.capture_time_ns())));
  return out;
}

}  // namespace thermovis::ros2_bridge
