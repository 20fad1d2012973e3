// thermovis-ros2: the fused image, ranges, detections and obstacles for ROS 2 (rt/thermovis/...),
// published only while a ROS 2 node subscribes.
#include <CLI/CLI.hpp>
#include <iostream>

#include "ros2_bridge_node.hpp"
#include "thermovis/node/service.hpp"

int main(int argc, char** argv) {
  using namespace thermovis;
  node::ServiceApp app("thermovis-ros2",
                       "republishes the pipeline as ROS 2 topics (sensor_msgs/Image, "
                       "thermovis_msgs) on a UDP participant");
  transport::ParticipantConfig ros;
  ros.profile = transport::kUdpProfile;
  ros.domain_id = -1;
  ros2_bridge::Ros2BridgeConfig config;
  app.add_option("--ros-domain", ros.domain_id,
                 "DDS domain of the ROS 2 topics (ROS_DOMAIN_ID; default: --domain)")
      ->check(CLI::Range(0, 232));
  app.add_option("--ros-profile", ros.profile, "DDS participant profile of the ROS 2 side")
      ->capture_default_str();
  app.add_option("--ros-profiles-file", ros.profiles_file,
                 "profile file of --ros-profile (default: the shipped one)");
  app.add_option("--image-frame-id", config.image_frame_id, "header.frame_id of the image")
      ->capture_default_str();
  app.add_option("--ranges-frame-id", config.ranges_frame_id, "header.frame_id of the ranges")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  return node::run_service(app.common, [&] {
    auto pipeline = node::make_participant(app.common);
    if (ros.domain_id < 0) ros.domain_id = pipeline->domain_id();
    ros.name = app.common.service + "-ros";
    transport::Participant ros_participant(ros);
    ros2_bridge::Ros2BridgeNode bridge(*pipeline, ros_participant, config, app.common.service);
    bridge.run();
    const auto& s = bridge.stats();
    std::cerr << app.common.service << ": published " << s.images << " images, " << s.ranges
              << " range arrays, " << s.detections << " detection arrays, " << s.obstacles
              << " obstacle arrays; dropped unsubscribed " << s.unsubscribed << ", overwritten "
              << s.overwritten << ", bad " << s.bad << "\n";
  });
}
