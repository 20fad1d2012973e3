#pragma once
// Topic names of the pipeline (docs/topics.md). thermovis/ranges with type
// thermovis::RangeArray is the public contract for other DDS applications.
namespace thermovis::transport::topics {

inline constexpr const char* kVisibleFrames = "thermovis/frames/visible";    // VisibleStereoFrame
inline constexpr const char* kInfraredFrames = "thermovis/frames/infrared";  // InfraredStereoFrame
inline constexpr const char* kRectifiedVisible =
    "thermovis/rectified/visible";  // GridStereoFrame, BGR8
inline constexpr const char* kRectifiedInfrared =
    "thermovis/rectified/infrared";                       // GridStereoFrame, MONO16 raw counts
inline constexpr const char* kFused = "thermovis/fused";  // GridStereoFrame
// GridGeometry: the grid frames' geometry, latched (public contract, like kRanges).
inline constexpr const char* kGeometry = "thermovis/geometry";
inline constexpr const char* kDetections = "thermovis/detections";  // DetectionArray
inline constexpr const char* kMatches = "thermovis/matches";        // MatchArray
inline constexpr const char* kRanges = "thermovis/ranges";          // RangeArray
// ObstacleArray: obstacles and free space (public contract, like kRanges).
inline constexpr const char* kObstacles = "thermovis/obstacles";
inline constexpr const char* kTiming = "thermovis/timing";  // FrameTiming
inline constexpr const char* kHealth = "thermovis/health";  // Health (keyed by service)
// GridStereoFrame, BGR8: the fusion-ranging image (left; right is black), from thermovis-view.
inline constexpr const char* kDisplay = "thermovis/display";

// The ROS 2 republication (thermovis-ros2): ROS 2 maps its topic /thermovis/... to the DDS topic
// rt/thermovis/... (types in idl/ros2/).
inline constexpr const char* kRos2FusedImage = "rt/thermovis/fused/image";  // sensor_msgs/Image
inline constexpr const char* kRos2Ranges = "rt/thermovis/ranges";  // thermovis_msgs/RangeArray
inline constexpr const char* kRos2Detections =
    "rt/thermovis/detections";  // thermovis_msgs/DetectionArray
inline constexpr const char* kRos2Obstacles =
    "rt/thermovis/obstacles";  // thermovis_msgs/ObstacleArray

}  // namespace thermovis::transport::topics
