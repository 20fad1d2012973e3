// thermovis record: the topics of a running pipeline into an MCAP file (Foxglove, ROS 2 tools,
// `thermovis replay`), or with --ros2 into a ROS 2 bag folder (`ros2 bag play`) of the topics
// thermovis-ros2 publishes. Each sample is stored as CDR bytes (those DDS carried, or those of
// the ROS 2 message the bridge makes of it), with the time it was received (log time) and the
// time its writer published it.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "command.hpp"
#include "recording.hpp"
#include "ros2_bag.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/record/foxglove.hpp"
#include "thermovis/record/mcap.hpp"
#include "thermovis/ros2_bridge/ros2_messages.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

namespace tv = thermovis;
using tv::cli::RecordableTopic;
using tv::cli::TappedSample;

struct Options {
  tv::node::CommonOptions common;
  std::filesystem::path out;
  std::filesystem::path ros2;  // a ROS 2 bag folder instead of `out`
  std::string topics;
  double seconds = 0.0;
  std::string compression = "zstd";
  int zstd_level = 1;
  double buffer_mb = 1024.0;
  double wait_s = 10.0;
  bool json = false;
  std::string images = tv::transport::topics::kFused;  // frame topics recorded as pictures
  tv::cli::ImageViewOptions image;
  bool scene = true;
};

const std::vector<std::string>& default_topics() {
  namespace t = tv::transport::topics;
  static const std::vector<std::string> names{t::kVisibleFrames, t::kInfraredFrames, t::kDetections,
                                              t::kMatches,       t::kRanges,         t::kObstacles,
                                              t::kTiming};
  return names;
}

struct TopicCount {
  std::uint64_t recorded = 0;
  std::uint64_t missed = 0;   // published, but overwritten before the reader took or copied them
  std::uint64_t dropped = 0;  // taken, but the write buffer was full (the disk fell behind)
  std::uint64_t failed = 0;   // taken, but no message could be made of them (`failure` says why)
  std::string failure;        // the first failure's reason
  std::uint64_t bytes = 0;
};

// Samples on their way from the DDS threads to the file, bounded in bytes.
class SampleQueue {
 public:
  struct Item {
    std::size_t source;  // index of the tap it came from
    std::uint64_t log_ns;
    TappedSample sample;
  };
  explicit SampleQueue(std::size_t max_bytes) : max_bytes_(max_bytes) {}

  // False when the sample does not fit (dropped).
  bool push(std::size_t source, TappedSample&& sample) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (bytes_ + sample.data.size() > max_bytes_ && !items_.empty()) return false;
    bytes_ += sample.data.size();
    // The log time is taken under the lock: the file's messages are in log-time order.
    items_.push_back(
        {source, static_cast<std::uint64_t>(tv::transport::now_ns()), std::move(sample)});
    ready_.notify_one();
    return true;
  }
  std::optional<Item> pop(std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!ready_.wait_for(lock, timeout, [&] { return !items_.empty(); })) return std::nullopt;
    Item item = std::move(items_.front());
    items_.pop_front();
    bytes_ -= item.sample.data.size();
    return item;
  }

 private:
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Item> items_;
  std::size_t bytes_ = 0;
  std::size_t max_bytes_;
};

int run_record(const Options& opt) {
  tv::node::install_stop_handlers();
  const bool bag = !opt.ros2.empty();
  if (!bag && opt.out.empty())
    throw std::invalid_argument("where to record: --out FILE.mcap or --ros2 DIR is needed");
  const auto topics = bag ? std::vector<RecordableTopic>{}
                          : tv::cli::parse_topic_list(opt.topics, default_topics());
  tv::record::McapWriterOptions wo;
  wo.library = "thermovis record";
  if (bag) wo.profile = tv::cli::kRos2Profile;
  wo.compression = opt.compression == "zstd" ? tv::record::McapCompression::zstd
                                             : tv::record::McapCompression::none;
  wo.zstd_level = opt.zstd_level;
  const std::filesystem::path file = bag ? tv::cli::create_ros2_bag_folder(opt.ros2) : opt.out;
  tv::record::McapWriter writer(file, wo);
  auto participant = tv::node::make_participant(opt.common);

  // Every source of messages: the DDS topics as CDR, then Foxglove's views of them as JSON.
  struct Source {
    std::string name;  // the channel's topic
    std::uint16_t channel;
    std::unique_ptr<tv::cli::TopicTap> tap;
  };
  std::vector<Source> sources;
  std::map<std::string, std::uint16_t> schema_of_type;
  const auto schema_id = [&](const std::string& name, const std::string& encoding,
                             const std::function<std::string()>& text) {
    auto schema = schema_of_type.find(name);
    if (schema == schema_of_type.end())
      schema = schema_of_type.emplace(name, writer.add_schema(name, encoding, text())).first;
    return schema->second;
  };
  for (const RecordableTopic& topic : topics) {
    const auto schema =
        schema_id(topic.type_name, "omgidl", [&] { return tv::cli::schema_text(topic); });
    sources.push_back({topic.topic, writer.add_channel(schema, topic.topic, "cdr"),
                       tv::cli::make_tap(*participant, topic)});
  }
  // A ROS 2 bag: the bridge's topics as rosbag2 stores them, nothing else.
  std::vector<tv::cli::Ros2BagTopicCount> bag_topics;
  for (const auto& topic :
       bag ? tv::cli::ros2_bag_topics() : std::vector<tv::cli::Ros2BagTopic>{}) {
    const auto schema = schema_id(topic.type, "ros2msg",
                                  [&] { return tv::ros2_bridge::ros2msg_definition(topic.type); });
    bag_topics.push_back({topic.name, topic.type, tv::cli::offered_qos_profiles(topic.qos), 0});
    sources.push_back(
        {topic.name,
         writer.add_channel(schema, topic.name, "cdr",
                            {{"offered_qos_profiles", bag_topics.back().offered_qos_profiles}}),
         tv::cli::make_ros2_tap(*participant, topic, opt.image.rate_hz)});
  }
  const auto& image_schema = tv::record::compressed_image_schema();
  for (const RecordableTopic& topic : opt.images == "none" || bag
                                          ? std::vector<RecordableTopic>{}
                                          : tv::cli::parse_topic_list(opt.images, {})) {
    const auto schema =
        schema_id(image_schema.name, "jsonschema", [&] { return image_schema.json_schema; });
    const std::string name = tv::cli::image_view_channel(topic);
    sources.push_back({name, writer.add_channel(schema, name, "json"),
                       tv::cli::make_image_view_tap(*participant, topic, opt.image)});
  }
  if (opt.scene && !bag) {
    const auto& scene_schema = tv::record::scene_update_schema();
    const auto schema =
        schema_id(scene_schema.name, "jsonschema", [&] { return scene_schema.json_schema; });
    sources.push_back({tv::cli::kSceneChannel,
                       writer.add_channel(schema, tv::cli::kSceneChannel, "json"),
                       tv::cli::make_scene_view_tap(*participant)});
    // The rig's cameras, once at the start: where the scene's "visible.left" frame and the
    // images' camera frames are.
    const auto& transforms_schema = tv::record::frame_transforms_schema();
    const auto channel =
        writer.add_channel(schema_id(transforms_schema.name, "jsonschema",
                                     [&] { return transforms_schema.json_schema; }),
                           tv::cli::kTransformsChannel, "json");
    const std::string json = tv::record::frame_transforms_json(
        tv::transport::now_ns(),
        tv::cli::rig_transforms(tv::runtime::load_rig_or_default(opt.common.rig)));
    const auto now = static_cast<std::uint64_t>(tv::transport::now_ns());
    writer.write(channel, 0, now, now, json.data(), json.size());
  }

  // The writers first: --seconds counts from when every topic has one (on a loaded machine
  // discovery can take seconds), so a timed recording is not spent waiting for them.
  const auto wait_until = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<std::int64_t>(opt.wait_s * 1000));
  for (const Source& source : sources) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        wait_until - std::chrono::steady_clock::now());
    if (!source.tap->wait_for_writers(std::max(left, std::chrono::milliseconds(0))) &&
        !tv::node::stop_requested())
      std::cerr << "thermovis record: no writer for " << source.name << " after " << opt.wait_s
                << " s; recording anyway" << std::endl;
  }

  SampleQueue queue(static_cast<std::size_t>(opt.buffer_mb * 1024 * 1024));
  std::vector<TopicCount> counts(sources.size());
  std::mutex counts_mutex;
  std::atomic<bool> stop_taps{false};
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    threads.emplace_back([&, i] {
      const auto sink = [&](TappedSample&& sample) {
        using Status = TappedSample::Status;
        const Status status = sample.status;
        std::uint64_t missed = sample.missed_before;
        if (status == Status::overwritten) ++missed;
        const bool queued = status == Status::recorded && queue.push(i, std::move(sample));
        std::lock_guard<std::mutex> lock(counts_mutex);
        counts[i].missed += missed;
        if (status == Status::recorded && !queued) ++counts[i].dropped;
        if (status == Status::failed && counts[i].failed++ == 0) {
          // Said at once: a channel that records nothing must not look like a quiet topic.
          counts[i].failure = sample.failure;
          std::cerr << "thermovis record: " << sources[i].name
                    << ": a sample cannot be recorded (counted as failed, and so are the next "
                       "ones): "
                    << sample.failure << std::endl;
        }
      };
      while (!stop_taps) sources[i].tap->poll(std::chrono::milliseconds(100), sink);
    });
  }
  const bool json = opt.json;
  if (!json) {
    std::cout << "thermovis record: " << sources.size() << " channels from DDS domain "
              << opt.common.domain << " into " << file.string() << " (Ctrl-C stops)" << std::endl;
  }
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::uint64_t payload_bytes = 0;
  const auto write = [&](SampleQueue::Item& item) {
    const auto& s = item.sample;
    writer.write(sources[item.source].channel, static_cast<std::uint32_t>(s.writer_sequence),
                 item.log_ns, static_cast<std::uint64_t>(s.publish_ns), s.data.data(),
                 s.data.size());
    payload_bytes += s.data.size();
    std::lock_guard<std::mutex> lock(counts_mutex);
    ++counts[item.source].recorded;
    counts[item.source].bytes += s.data.size();
  };
  while (!tv::node::stop_requested() && (opt.seconds <= 0 || elapsed() < opt.seconds)) {
    if (auto item = queue.pop(std::chrono::milliseconds(100))) write(*item);
  }
  stop_taps = true;
  for (auto& t : threads) t.join();
  while (auto item = queue.pop(std::chrono::milliseconds(0))) write(*item);
  const double seconds = elapsed();
  writer.close();
  if (bag) {
    // The channels of the bag are sources 0.. in the order of bag_topics.
    for (std::size_t i = 0; i < bag_topics.size(); ++i) {
      const auto& per_channel = writer.statistics().channel_message_counts;
      const auto count = per_channel.find(sources[i].channel);
      bag_topics[i].message_count = count == per_channel.end() ? 0 : count->second;
    }
    tv::cli::write_ros2_bag_metadata(file, writer.statistics(), bag_topics);
  }

  const double file_mb = static_cast<double>(std::filesystem::file_size(file)) / 1e6;
  nlohmann::json per_topic = nlohmann::json::object();
  std::uint64_t missed = 0, dropped = 0, failed = 0;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    per_topic[sources[i].name] = {{"recorded", counts[i].recorded},
                                  {"missed", counts[i].missed},
                                  {"dropped", counts[i].dropped},
                                  {"failed", counts[i].failed},
                                  {"mb", static_cast<double>(counts[i].bytes) / 1e6}};
    if (counts[i].failed > 0) per_topic[sources[i].name]["failure"] = counts[i].failure;
    missed += counts[i].missed;
    dropped += counts[i].dropped;
    failed += counts[i].failed;
  }
  const nlohmann::json summary{
      {"file", file.string()},
      {"seconds", seconds},
      {"messages", writer.statistics().message_count},
      {"payload_mb", static_cast<double>(payload_bytes) / 1e6},
      {"file_mb", file_mb},
      {"record_mb_per_s", static_cast<double>(payload_bytes) / 1e6 / seconds},
      {"missed", missed},
      {"dropped", dropped},
      {"failed", failed},
      {"topics", per_topic}};
  if (json) {
    std::cout << summary.dump() << std::endl;
  } else {
    std::cout << std::fixed << std::setprecision(1) << "recorded " << summary["messages"]
              << " messages in " << seconds << " s: " << summary["payload_mb"].get<double>()
              << " MB of samples (" << summary["record_mb_per_s"].get<double>() << " MB/s), file "
              << file_mb << " MB\n";
    for (std::size_t i = 0; i < sources.size(); ++i) {
      std::cout << "  " << std::left << std::setw(34) << sources[i].name << std::right
                << std::setw(8) << counts[i].recorded << " recorded" << std::setw(8)
                << counts[i].missed << " missed" << std::setw(8) << counts[i].dropped << " dropped"
                << std::setw(8) << counts[i].failed << " failed\n";
      if (counts[i].failed > 0) std::cout << "    failed: " << counts[i].failure << "\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND(
    "record", "record pipeline topics into an MCAP file (Foxglove, ROS 2 tools, thermovis replay)",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      opt->common.service = "thermovis-record";
      thermovis::node::add_common_options(app, opt->common);
      app.footer(
          "Sizes: a capture is a visible frame (12.4 MB on the wire: the type holds the full "
          "1920x1080 pair) and an infrared frame (3.1 MB), so raw captures at 50 Hz are about "
          "780 MB/s; the small topics are a few kB per frame. zstd level 1 keeps up with a few "
          "captures a second on one core (run the bridge at a lower --rate to record every "
          "capture). Captures the recorder could not take before the next ones replaced them "
          "are counted as missed (so are frames their writer overwrote while they were copied), "
          "samples the disk could not keep up with as dropped, samples no message could be made "
          "of (a corrupt frame header) as failed, with the reason: all are reported at the "
          "end.");
      auto* out = app.add_option("--out", opt->out, "MCAP file to write");
      auto* ros2 = app.add_option(
          "--ros2", opt->ros2,
          "instead of --out: a ROS 2 bag folder (new or empty) for `ros2 bag play`, of the topics "
          "thermovis-ros2 publishes (/thermovis/fused/image at most --image-rate a second, "
          "/thermovis/ranges, /thermovis/detections: every one) as rosbag2 writes them with its "
          "MCAP storage");
      out->excludes(ros2);
      auto* topic_list =
          app.add_option("--topics", opt->topics,
                         "comma-separated topics (default: the raw captures, detections, matches, "
                         "ranges and timing)");
      app.add_option("--seconds", opt->seconds, "stop after this long (0: at SIGINT/SIGTERM)")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      app.add_option("--compression", opt->compression, "chunk compression")
          ->capture_default_str()
          ->check(CLI::IsMember({"zstd", "none"}));
      app.add_option("--zstd-level", opt->zstd_level, "zstd level (1: fastest)")
          ->capture_default_str()
          ->check(CLI::Range(1, 19));
      app.add_option("--buffer-mb", opt->buffer_mb,
                     "samples held in memory while the file catches up, MB; beyond it they are "
                     "dropped and counted")
          ->capture_default_str()
          ->check(CLI::PositiveNumber);
      app.add_option("--wait", opt->wait_s,
                     "wait this long for a writer on every topic before recording starts, s")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      auto* images =
          app.add_option(
                 "--images", opt->images,
                 "comma-separated frame topics also recorded as pictures Foxglove shows "
                 "(foxglove.CompressedImage of the left eye on <topic>/left/compressed: JPEG, "
                 "or lossless 16-bit PNG for raw infrared), or none")
              ->capture_default_str();
      app.add_option("--image-rate", opt->image.rate_hz,
                     "pictures a second per --images topic, and images a second on a --ros2 "
                     "bag's /thermovis/fused/image, at most (by capture time; 0: every "
                     "frame received, about 1.6 MB each in a bag)")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      auto* jpeg_quality =
          app.add_option("--jpeg-quality", opt->image.jpeg_quality, "JPEG quality of the pictures")
              ->capture_default_str()
              ->check(CLI::Range(1, 100));
      auto* no_scene =
          app.add_flag("!--no-scene", opt->scene,
                       "no foxglove.SceneUpdate of the ranges (thermovis/scene) and no "
                       "foxglove.FrameTransforms of the rig's cameras (thermovis/transforms)");
      app.add_flag("--json", opt->json, "print the summary as one JSON object");
      // A ROS 2 bag holds the bridge's topics only: no pipeline topics, pictures or scene.
      for (auto* option : {topic_list, images, jpeg_quality, no_scene}) ros2->excludes(option);
      return [opt] { return run_record(*opt); };
    });

}  // namespace
