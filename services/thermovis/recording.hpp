#pragma once
// What `thermovis record` and `thermovis replay` share: the table of recordable topics (name,
// IDL type, QoS), a tap that takes one topic's samples as CDR bytes (the serialized payload
// DDS sends, with its encapsulation header: MCAP message encoding "cdr"), and a player that
// publishes such bytes back on the topic (frames into loaned data-sharing samples, as the
// bridge does).
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "thermovis/camera/rig.hpp"
#include "thermovis/record/foxglove.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"

namespace thermovis::cli {

struct RecordableTopic {
  std::string topic;      // e.g. "thermovis/ranges"
  std::string type_name;  // IDL name, e.g. "thermovis::RangeArray" (the MCAP schema name)
  std::string idl_file;   // the IDL file declaring it, e.g. "thermovis/perception.idl"
  bool frame = false;     // a plain frame type (megabytes; data-sharing with loans)
  transport::TopicQos qos;
};

// Every topic of topics.hpp.
const std::vector<RecordableTopic>& recordable_topics();
// The entry of `topic`; throws std::invalid_argument listing the known topics.
const RecordableTopic& recordable_topic(const std::string& topic);
// "a,b,c" -> entries; empty -> `defaults`.
std::vector<RecordableTopic> parse_topic_list(const std::string& list,
                                              const std::vector<std::string>& defaults);

// The self-contained IDL text of a topic's type (MCAP schema encoding "omgidl"): its IDL file with
// the files it includes inlined, as built into this executable, with its constant expressions
// folded to literals (record::fold_constant_expressions).
std::string schema_text(const RecordableTopic& topic);

// One sample a tap took, and what became of it: recorded (its message bytes), skipped by a rate
// limit, overwritten (a frame's data-sharing slot reused by its writer while it was copied: a
// torn copy, not recorded), or failed (no message could be made of it: `failure` says why).
struct TappedSample {
  enum class Status { recorded, skipped, overwritten, failed };
  Status status = Status::recorded;
  std::vector<std::uint8_t> data;     // CDR (make_tap) or a Foxglove JSON message (make_*_view_tap)
  std::string failure;                // Status::failed: what is wrong with the sample
  std::int64_t publish_ns = 0;        // the writer's source timestamp
  std::uint64_t writer_sequence = 0;  // the writer's sequence number of the sample
  std::uint64_t missed_before = 0;    // samples of that writer this reader never got before it
};

// At most one sample per period, by capture time (a capture time that goes back, as when a replay
// starts over, starts the count again). A rate of 0 lets every sample through.
class RateLimit {
 public:
  explicit RateLimit(double rate_hz);
  // Whether a sample captured at `capture_ns` is due.
  bool due(std::int64_t capture_ns) const;
  // A sample captured at `capture_ns` was recorded (or tried): the next is due a period later.
  void mark(std::int64_t capture_ns);

 private:
  std::int64_t period_ns_ = 0;
  std::optional<std::int64_t> last_ns_;
};

// Takes one topic's samples. Not thread-safe; one thread per tap.
class TopicTap {
 public:
  virtual ~TopicTap() = default;
  // Waits up to `timeout` for samples and hands each to `sink`, whatever its status (a sample
  // that cannot be encoded is reported as failed, never thrown). Returns the number taken.
  virtual std::size_t poll(std::chrono::milliseconds timeout,
                           const std::function<void(TappedSample&&)>& sink) = 0;
  // True once a writer of the topic has matched this tap (false on timeout).
  virtual bool wait_for_writers(std::chrono::milliseconds timeout) = 0;
};
std::unique_ptr<TopicTap> make_tap(transport::Participant& participant,
                                   const RecordableTopic& topic);

// Views of the pipeline in Foxglove's own message types (JSON, record/foxglove.hpp), recorded
// beside the CDR topics.
struct ImageViewOptions {
  double rate_hz = 2.0;   // at most this many images a second (by capture time); 0: every one
  int jpeg_quality = 80;  // 1..100, for 8-bit images; raw 16-bit infrared is a lossless PNG
};
// The channel of a frame topic's image view: "<topic>/left/compressed" (the left eye).
std::string image_view_channel(const RecordableTopic& frame_topic);
// The camera frame (rig camera name) a frame topic's left image is in: "visible.left" or
// "infrared.left" (the rectified and fused grids are on their left camera's rectified grid).
std::string image_frame_id(const RecordableTopic& frame_topic);
// foxglove.CompressedImage of the left eye of `frame_topic`'s frames, at options.rate_hz. The
// pixels are copied out of the frame before they are compressed, so a writer reusing the frame's
// slot meanwhile costs no picture. Throws std::invalid_argument for a topic that is not a frame
// topic or a negative rate.
std::unique_ptr<TopicTap> make_image_view_tap(transport::Participant& participant,
                                              const RecordableTopic& frame_topic,
                                              const ImageViewOptions& options);
// foxglove.SceneUpdate of thermovis/ranges: each target a box at its position in the
// "visible.left" camera frame, labelled with its class and distance.
inline constexpr const char* kSceneChannel = "thermovis/scene";
std::unique_ptr<TopicTap> make_scene_view_tap(transport::Participant& participant);
// foxglove.FrameTransforms of the rig: each camera (by its rig name, e.g. "infrared.left") in
// the "rig" frame (the rig's reference camera frame), from the rig's extrinsics.
inline constexpr const char* kTransformsChannel = "thermovis/transforms";
std::vector<record::FrameTransform> rig_transforms(const camera::Rig& rig);

// A topic of a ROS 2 bag (`thermovis record --ros2`): one that thermovis-ros2 publishes, made
// by the same conversion (ros2_bridge/ros2_messages.hpp) from the pipeline topic it reads.
struct Ros2BagTopic {
  std::string name;         // ROS 2 topic (no "rt"), e.g. "/thermovis/ranges"
  std::string type;         // ROS 2 type, e.g. "thermovis_msgs/msg/RangeArray"
  std::string source;       // the pipeline topic it is made from, e.g. "thermovis/ranges"
  transport::TopicQos qos;  // what the bridge's writer offers
};
// The bridge's topics: the fused image, the ranges and the detections.
const std::vector<Ros2BagTopic>& ros2_bag_topics();
// Takes `topic.source`'s samples and records each as the CDR serialized payload of the ROS 2
// message the bridge would publish for it (message encoding "cdr", as rosbag2 stores them). The
// fused image at most `image_rate_hz` a second, by capture time (0: every frame received).
std::unique_ptr<TopicTap> make_ros2_tap(transport::Participant& participant,
                                        const Ros2BagTopic& topic, double image_rate_hz);

// Publishes recorded samples on one topic.
class TopicPlayer {
 public:
  virtual ~TopicPlayer() = default;
  // Deserializes `cdr` and publishes it, with every capture and stage time moved by
  // `time_shift_ns`. False when the sample was dropped because every pool slot of a frame topic
  // is held by readers (the bridge drops a capture the same way). Throws std::runtime_error when
  // the bytes do not decode as the topic's type.
  virtual bool publish(const std::uint8_t* cdr, std::size_t size, std::int64_t time_shift_ns) = 0;
  virtual bool wait_for_readers(std::chrono::milliseconds timeout) = 0;
};
std::unique_ptr<TopicPlayer> make_player(transport::Participant& participant,
                                         const RecordableTopic& topic);

}  // namespace thermovis::cli
