#include "recording.hpp"

#include <Eigen/Geometry>
#include <iomanip>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "idl_text.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/record/foxglove.hpp"
#include "thermovis/record/idl_schema.hpp"
#include "thermovis/ros2_bridge/ros2_messages.hpp"
#include "thermovis/ros2_bridge/ros2_types.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topic_types.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::cli {

namespace topics = transport::topics;
using eprosima::fastrtps::rtps::SerializedPayload_t;

namespace {

// Readers of the rectified grids on the rectify-fuse's writers (rectify_fuse_node.cpp).
constexpr std::int32_t kGridFrameReaders = 4;

}  // namespace

const std::vector<RecordableTopic>& recordable_topics() {
  using transport::frame_topic_qos;
  static const std::vector<RecordableTopic> table{
      {topics::kVisibleFrames, "thermovis::VisibleStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos()},
      {topics::kInfraredFrames, "thermovis::InfraredStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos()},
      {topics::kRectifiedVisible, "thermovis::GridStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos(transport::kDefaultFrameDeadline, 2, kGridFrameReaders)},
      {topics::kRectifiedInfrared, "thermovis::GridStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos(transport::kDefaultFrameDeadline, 2, kGridFrameReaders)},
      {topics::kFused, "thermovis::GridStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos(transport::kDefaultFrameDeadline, 2, kGridFrameReaders)},
      {topics::kDisplay, "thermovis::GridStereoFrame", "thermovis/frames.idl", true,
       frame_topic_qos()},
      {topics::kDetections, "thermovis::DetectionArray", "thermovis/perception.idl", false,
       transport::event_topic_qos()},
      {topics::kMatches, "thermovis::MatchArray", "thermovis/perception.idl", false,
       transport::event_topic_qos()},
      {topics::kRanges, "thermovis::RangeArray", "thermovis/perception.idl", false,
       transport::event_topic_qos()},
      {topics::kObstacles, "thermovis::ObstacleArray", "thermovis/obstacles.idl", false,
       transport::event_topic_qos()},
      {topics::kTiming, "thermovis::FrameTiming", "thermovis/perception.idl", false,
       transport::event_topic_qos()},
      {topics::kHealth, "thermovis::Health", "thermovis/health.idl", false,
       transport::state_topic_qos()},
  };
  return table;
}

const RecordableTopic& recordable_topic(const std::string& topic) {
  std::string known;
  for (const auto& t : recordable_topics()) {
    if (t.topic == topic) return t;
    known += (known.empty() ? "" : ", ") + t.topic;
  }
  throw std::invalid_argument("unknown topic '" + topic + "' (known: " + known + ")");
}

std::vector<RecordableTopic> parse_topic_list(const std::string& list,
                                              const std::vector<std::string>& defaults) {
  std::vector<std::string> names;
  std::istringstream in(list);
  for (std::string name; std::getline(in, name, ',');) {
    if (!name.empty()) names.push_back(name);
  }
  if (names.empty()) names = defaults;
  std::vector<RecordableTopic> out;
  for (const auto& name : names) {
    for (const auto& o : out) {
      if (o.topic == name) throw std::invalid_argument("topic '" + name + "' listed twice");
    }
    out.push_back(recordable_topic(name));
  }
  return out;
}

std::string schema_text(const RecordableTopic& topic) {
  // Literal constants and bounds: Foxglove's IDL parser takes no expressions there.
  return record::fold_constant_expressions(
      record::flatten_idl(topic.idl_file, [](const std::string& file) {
        const auto& files = idl_files();
        const auto it = files.find(file);
        if (it == files.end())
          throw std::runtime_error("IDL file " + file + " is not built into this executable");
        return it->second;
      }));
}

namespace {

// The capture and stage times a replay moves to the present.
void shift_stamps(PipelineStamps& stamps, std::int64_t shift) {
  for (StageStamp& s : stamps.stamps()) {
    if (s.stage() != STAGE_NONE) s.end_ns(s.end_ns() + shift);
  }
}
template <class T>
void shift_times(T& sample, std::int64_t shift) {
  sample.capture_time_ns(sample.capture_time_ns() + shift);
  shift_stamps(sample.stamps(), shift);
}
void shift_times(FrameTiming& timing, std::int64_t shift) {
  timing.capture_time_ns(timing.capture_time_ns() + shift);
  timing.output_time_ns(timing.output_time_ns() + shift);
  shift_stamps(timing.stamps(), shift);
}
void shift_times(Health& health, std::int64_t shift) { health.time_ns(health.time_ns() + shift); }

template <class T>
constexpr bool kIsFrame =
    std::is_same_v<T, VisibleStereoFrame> || std::is_same_v<T, InfraredStereoFrame> ||
    std::is_same_v<T, GridStereoFrame>;

// A payload over bytes this code owns: Fast DDS frees `data` in the destructor, so it is
// detached first.
struct BorrowedPayload {
  SerializedPayload_t payload;
  BorrowedPayload(std::uint8_t* data, std::size_t size) {
    payload.data = data;
    payload.length = static_cast<std::uint32_t>(size);
    payload.max_size = static_cast<std::uint32_t>(size);
  }
  ~BorrowedPayload() { payload.data = nullptr; }
  BorrowedPayload(const BorrowedPayload&) = delete;
  BorrowedPayload& operator=(const BorrowedPayload&) = delete;
};

// `sample`'s CDR serialized payload (encapsulation header and data, as DDS sends it) into `out`.
template <class T, class PubSub>
void serialize_cdr(const std::string& topic, PubSub& pubsub, const T& sample,
                   std::vector<std::uint8_t>& out) {
  T* data = const_cast<T*>(&sample);  // Fast DDS's serialize takes void*, only reads
  out.resize(pubsub.getSerializedSizeProvider(data)());
  BorrowedPayload payload(out.data(), out.size());
  payload.payload.length = 0;
  if (!pubsub.serialize(data, &payload.payload))
    throw std::runtime_error(topic + ": a sample does not serialize");
  out.resize(payload.payload.length);
}

// The step that makes a taken sample's recorded bytes from what its Encode copied out of it, run
// once the copy is known not torn (compressing a picture takes longer than a writer may leave a
// data-sharing slot alone).
using Finish = std::function<void(std::vector<std::uint8_t>& out)>;
// What a tap records of one taken sample: its bytes into `out` (and, when they take long to make,
// a copy of what they are made from and the `finish` that makes them), or false to skip it.
// Throws, naming what is wrong, when no message can be made of the sample.
template <class T>
using Encode = std::function<bool(const T& sample, std::vector<std::uint8_t>& out, Finish& finish)>;

template <class T>
class Tap final : public TopicTap {
 public:
  // `encode` empty: the sample's CDR serialized payload.
  Tap(transport::Participant& participant, const RecordableTopic& topic, Encode<T> encode = {})
      : topic_(topic.topic),
        reader_(participant, topic.topic, tap_qos(topic)),
        encode_(std::move(encode)) {}

  std::size_t poll(std::chrono::milliseconds timeout,
                   const std::function<void(TappedSample&&)>& sink) override {
    using Status = TappedSample::Status;
    reader_.wait_for_data(timeout);
    auto samples = reader_.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      TappedSample out;
      const auto& info = samples.info(i);
      out.publish_ns = info.source_timestamp.to_ns();
      out.writer_sequence = info.sample_identity.sequence_number().to64long();
      // Every sample taken counts, whatever becomes of it: a gap is what DDS never delivered.
      auto& last = last_sequence_[info.sample_identity.writer_guid()];
      if (last != 0 && out.writer_sequence > last + 1)
        out.missed_before = out.writer_sequence - last - 1;
      last = out.writer_sequence;
      Finish finish;
      try {
        if (!(encode_ ? encode_(samples[i], out.data, finish) : serialize(samples[i], out.data)))
          out.status = Status::skipped;
      } catch (const std::exception& e) {
        out.status = Status::failed;
        out.failure = e.what();
      }
      // A frame's data-sharing slot reused by its writer while it was copied: a torn copy (and a
      // failure made of one says nothing about the sample).
      if (out.status != Status::skipped && !samples.still_valid(i)) {
        out.status = Status::overwritten;
        out.failure.clear();
      }
      if (out.status == Status::recorded && finish) {
        try {
          finish(out.data);
        } catch (const std::exception& e) {
          out.status = Status::failed;
          out.failure = e.what();
        }
      }
      if (out.status != Status::recorded) out.data.clear();
      sink(std::move(out));
    }
    return samples.size();
  }

  bool wait_for_writers(std::chrono::milliseconds timeout) override {
    return reader_.wait_for_writers(1, timeout);
  }

 private:
  static transport::TopicQos tap_qos(const RecordableTopic& topic) {
    transport::TopicQos qos = transport::observer_qos(topic.qos);
    if (qos.kind == transport::TopicKind::event) qos.depth = 64;  // rides out a slow disk
    return qos;
  }
  bool serialize(const T& taken, std::vector<std::uint8_t>& out) {
    serialize_cdr(topic_, pubsub_, taken, out);
    return true;
  }
  std::string topic_;
  transport::Reader<T> reader_;
  Encode<T> encode_;
  typename transport::TypeSupportOf<T>::type pubsub_;
  std::map<eprosima::fastrtps::rtps::GUID_t, std::uint64_t> last_sequence_;
};

template <class T>
class Player final : public TopicPlayer {
 public:
  Player(transport::Participant& participant, const RecordableTopic& topic)
      : topic_(topic.topic), writer_(participant, topic.topic, topic.qos) {}

  bool publish(const std::uint8_t* cdr, std::size_t size, std::int64_t time_shift_ns) override {
    BorrowedPayload payload(const_cast<std::uint8_t*>(cdr), size);  // deserialize only reads
    if constexpr (kIsFrame<T>) {
      std::optional<transport::Loan<T>> loan;
      try {
        loan.emplace(writer_.loan());
      } catch (const std::runtime_error&) {
        return false;  // every slot held by readers: dropped, as the bridge drops a capture
      }
      decode(payload, loan->get());
      shift_times(**loan, time_shift_ns);
      writer_.publish(std::move(*loan));
    } else {
      T sample;
      decode(payload, &sample);
      shift_times(sample, time_shift_ns);
      writer_.write(sample);
    }
    return true;
  }

  bool wait_for_readers(std::chrono::milliseconds timeout) override {
    return writer_.wait_for_readers(1, timeout);
  }

 private:
  void decode(BorrowedPayload& payload, T* into) {
    bool ok = false;
    try {
      ok = pubsub_.deserialize(&payload.payload, into);
    } catch (const std::exception&) {
      ok = false;  // Fast CDR throws on a buffer that ends early
    }
    if (!ok)
      throw std::runtime_error(topic_ + ": a recorded sample of " +
                               std::to_string(payload.payload.length) +
                               " bytes does not decode as its type");
  }
  std::string topic_;
  transport::Writer<T> writer_;
  typename transport::TypeSupportOf<T>::type pubsub_;
};

// A type tag (the frame types are megabytes: never on the stack).
template <class T>
struct Tag {
  using type = T;
};

// Calls make(Tag<T>{}) with the generated type named `type_name`.
template <class Make>
auto with_type_tag(const std::string& type_name, Make&& make) {
  if (type_name == "thermovis::VisibleStereoFrame") return make(Tag<VisibleStereoFrame>{});
  if (type_name == "thermovis::InfraredStereoFrame") return make(Tag<InfraredStereoFrame>{});
  if (type_name == "thermovis::GridStereoFrame") return make(Tag<GridStereoFrame>{});
  if (type_name == "thermovis::DetectionArray") return make(Tag<DetectionArray>{});
  if (type_name == "thermovis::MatchArray") return make(Tag<MatchArray>{});
  if (type_name == "thermovis::RangeArray") return make(Tag<RangeArray>{});
  if (type_name == "thermovis::ObstacleArray") return make(Tag<ObstacleArray>{});
  if (type_name == "thermovis::FrameTiming") return make(Tag<FrameTiming>{});
  if (type_name == "thermovis::Health") return make(Tag<Health>{});
  throw std::invalid_argument("no DDS type " + type_name);
}

}  // namespace

std::unique_ptr<TopicTap> make_tap(transport::Participant& participant,
                                   const RecordableTopic& topic) {
  return with_type_tag(topic.type_name, [&](auto tag) -> std::unique_ptr<TopicTap> {
    using T = typename decltype(tag)::type;
    return std::make_unique<Tap<T>>(participant, topic);
  });
}

std::string image_view_channel(const RecordableTopic& frame_topic) {
  return frame_topic.topic + "/left/compressed";
}

std::string image_frame_id(const RecordableTopic& frame_topic) {
  const bool infrared = frame_topic.topic == topics::kInfraredFrames ||
                        frame_topic.topic == topics::kRectifiedInfrared;
  return infrared ? "infrared.left" : "visible.left";
}

RateLimit::RateLimit(double rate_hz) {
  if (!(rate_hz >= 0))
    throw std::invalid_argument("a rate must be 0 (every sample) or positive, got " +
                                std::to_string(rate_hz) + " Hz");
  if (rate_hz > 0) period_ns_ = static_cast<std::int64_t>(1e9 / rate_hz);
}

bool RateLimit::due(std::int64_t capture_ns) const {
  return !last_ns_ || capture_ns < *last_ns_ || capture_ns - *last_ns_ >= period_ns_;
}

void RateLimit::mark(std::int64_t capture_ns) { last_ns_ = capture_ns; }

std::unique_ptr<TopicTap> make_image_view_tap(transport::Participant& participant,
                                              const RecordableTopic& frame_topic,
                                              const ImageViewOptions& options) {
  if (!frame_topic.frame)
    throw std::invalid_argument("no images on " + frame_topic.topic + ": not a frame topic");
  auto limit = std::make_shared<RateLimit>(options.rate_hz);
  return with_type_tag(frame_topic.type_name, [&](auto tag) -> std::unique_ptr<TopicTap> {
    using T = typename decltype(tag)::type;
    if constexpr (!kIsFrame<T>) {
      throw std::invalid_argument("no images on " + frame_topic.topic);
    } else {
      Encode<T> encode = [limit, frame_id = image_frame_id(frame_topic),
                          quality = options.jpeg_quality](
                             const T& frame, std::vector<std::uint8_t>&, Finish& finish) {
        const std::int64_t t = frame.capture_time_ns();
        if (!limit->due(t)) return false;
        // The pixels out of the slot first: the writer may reuse it while they are compressed.
        const cv::Mat left = node::view(frame, node::Eye::left).clone();
        finish = [limit, t, frame_id, quality, left](std::vector<std::uint8_t>& out) {
          limit->mark(t);
          const std::string json =
              record::compressed_image_json(t, frame_id, record::encode_image(left, quality));
          out.assign(json.begin(), json.end());
        };
        return true;
      };
      return std::make_unique<Tap<T>>(participant, frame_topic, std::move(encode));
    }
  });
}

namespace {

std::vector<record::SceneBox> scene_boxes(const RangeArray& ranges) {
  std::vector<record::SceneBox> boxes;
  for (const TargetRange& t : ranges.targets()) {
    record::SceneBox b;
    b.id = "target " + std::to_string(t.target_id());
    std::ostringstream label;
    label << t.label().to_string() << " " << std::fixed << std::setprecision(1) << t.distance_m()
          << " m";
    b.label = label.str();
    b.centre_m = {t.x_m(), t.y_m(), t.z_m()};
    // Nominal sizes (width, height, depth; m): a range carries a position, not an extent.
    b.size_m = t.label().to_string() == "person" ? std::array<double, 3>{0.6, 1.75, 0.6}
                                                 : std::array<double, 3>{1.0, 1.0, 1.0};
    boxes.push_back(std::move(b));
  }
  return boxes;
}

}  // namespace

std::unique_ptr<TopicTap> make_scene_view_tap(transport::Participant& participant) {
  Encode<RangeArray> encode = [](const RangeArray& ranges, std::vector<std::uint8_t>& out,
                                 Finish&) {
    const std::string json =
        record::scene_update_json(ranges.capture_time_ns(), "visible.left", scene_boxes(ranges));
    out.assign(json.begin(), json.end());
    return true;
  };
  return std::make_unique<Tap<RangeArray>>(participant, recordable_topic(topics::kRanges),
                                           std::move(encode));
}

std::vector<record::FrameTransform> rig_transforms(const camera::Rig& rig) {
  std::vector<record::FrameTransform> out;
  for (const camera::RigCamera& camera : rig.cameras) {
    record::FrameTransform t;
    t.parent = "rig";
    t.child = camera.name;
    const Eigen::Vector3d p = camera.T_ref_cam.translation();
    const Eigen::Quaterniond q(camera.T_ref_cam.rotation());
    t.translation_m = {p.x(), p.y(), p.z()};
    t.rotation_xyzw = {q.x(), q.y(), q.z(), q.w()};
    out.push_back(std::move(t));
  }
  return out;
}

const std::vector<Ros2BagTopic>& ros2_bag_topics() {
  namespace ros = ros2_bridge;
  static const std::vector<Ros2BagTopic> table{
      {ros::ros2_topic_name(topics::kRos2FusedImage),
       ros::ros2_type_name(
           transport::TypeSupportOf<sensor_msgs::msg::dds_::Image_>::type().getName()),
       topics::kFused, transport::event_topic_qos()},
      {ros::ros2_topic_name(topics::kRos2Ranges),
       ros::ros2_type_name(
           transport::TypeSupportOf<thermovis_msgs::msg::dds_::RangeArray_>::type().getName()),
       topics::kRanges, transport::event_topic_qos()},
      {ros::ros2_topic_name(topics::kRos2Detections),
       ros::ros2_type_name(
           transport::TypeSupportOf<thermovis_msgs::msg::dds_::DetectionArray_>::type().getName()),
       topics::kDetections, transport::event_topic_qos()},
      {ros::ros2_topic_name(topics::kRos2Obstacles),
       ros::ros2_type_name(
           transport::TypeSupportOf<thermovis_msgs::msg::dds_::ObstacleArray_>::type().getName()),
       topics::kObstacles, transport::event_topic_qos()},
  };
  return table;
}

namespace {

// A tap of `source` recording each sample as ROS 2 message M: `convert(sample, message)` (throws
// naming what is wrong with the sample), then M's CDR; at most `rate_hz` samples a second by
// capture time (0: every one).
template <class T, class M, class Convert>
std::unique_ptr<TopicTap> ros2_tap(transport::Participant& participant, const Ros2BagTopic& topic,
                                   Convert convert, double rate_hz = 0.0) {
  auto pubsub = std::make_shared<typename transport::TypeSupportOf<M>::type>();
  auto message = std::make_shared<M>();  // reused: an image's data buffer keeps its size
  auto limit = std::make_shared<RateLimit>(rate_hz);
  Encode<T> encode = [name = topic.name, pubsub, message, convert, limit](
                         const T& sample, std::vector<std::uint8_t>&, Finish& finish) {
    const std::int64_t t = sample.capture_time_ns();
    if (!limit->due(t)) return false;
    convert(sample, *message);
    finish = [name, pubsub, message, limit, t](std::vector<std::uint8_t>& out) {
      limit->mark(t);
      serialize_cdr(name, *pubsub, *message, out);
    };
    return true;
  };
  return std::make_unique<Tap<T>>(participant, recordable_topic(topic.source), std::move(encode));
}

}  // namespace

std::unique_ptr<TopicTap> make_ros2_tap(transport::Participant& participant,
                                        const Ros2BagTopic& topic, double image_rate_hz) {
  namespace ros = ros2_bridge;
  if (topic.source == topics::kFused) {
    // A frame with a corrupt header is reported (as failed, by the tap) and skipped, as the
    // bridge does.
    return ros2_tap<GridStereoFrame, sensor_msgs::msg::dds_::Image_>(
        participant, topic,
        [](const GridStereoFrame& frame, sensor_msgs::msg::dds_::Image_& m) {
          ros::to_ros_image(frame, ros::kImageFrameId, m);
        },
        image_rate_hz);
  }
  if (topic.source == topics::kRanges) {
    return ros2_tap<RangeArray, thermovis_msgs::msg::dds_::RangeArray_>(
        participant, topic,
        [](const RangeArray& ranges, thermovis_msgs::msg::dds_::RangeArray_& m) {
          m = ros::to_ros(ranges, ros::kRangesFrameId);
        });
  }
  if (topic.source == topics::kDetections) {
    return ros2_tap<DetectionArray, thermovis_msgs::msg::dds_::DetectionArray_>(
        participant, topic,
        [](const DetectionArray& detections, thermovis_msgs::msg::dds_::DetectionArray_& m) {
          m = ros::to_ros(detections, ros::kImageFrameId);
        });
  }
  if (topic.source == topics::kObstacles) {
    return ros2_tap<ObstacleArray, thermovis_msgs::msg::dds_::ObstacleArray_>(
        participant, topic,
        [](const ObstacleArray& obstacles, thermovis_msgs::msg::dds_::ObstacleArray_& m) {
          m = ros::to_ros(obstacles, ros::kRangesFrameId);
        });
  }
  throw std::invalid_argument("no ROS 2 message for pipeline topic " + topic.source);
}

std::unique_ptr<TopicPlayer> make_player(transport::Participant& participant,
                                         const RecordableTopic& topic) {
  return with_type_tag(topic.type_name, [&](auto tag) -> std::unique_ptr<TopicPlayer> {
    using T = typename decltype(tag)::type;
    return std::make_unique<Player<T>>(participant, topic);
  });
}

}  // namespace thermovis::cli
