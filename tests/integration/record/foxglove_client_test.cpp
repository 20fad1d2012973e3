// A recording opened as Foxglove opens it (issue 20): known samples are published on a private
// domain, `thermovis record` records every recordable topic (and its pictures, scene and rig
// transforms), and Foxglove's own npm packages (the MCAP reader, the OMG IDL parser and the CDR
// decoder; foxglove/check_recording.mjs) parse every channel's schema and decode every message.
// The decoded fields must equal what was published, and the decoded pictures the published
// images (exactly for the lossless 16-bit PNG of raw infrared).
// A ROS 2 bag (`thermovis record --ros2`) is read the same way with the npm packages ROS 2 tools
// outside ROS use (foxglove/check_ros2_bag.mjs: the yaml parser for metadata.yaml, @mcap/core,
// the ros2msg parser @foxglove/rosmsg and the CDR decoder @foxglove/rosmsg2-serialization).
// The packages are installed into the build tree by the test's set-up; where npm or node is
// missing the tests are skipped, saying so, except under CI (CI=true), where that fails them.
#include <gtest/gtest.h>

#include <array>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <thread>

#include "../pipeline/pipeline_harness.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topic_types.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::ChildProcess;
namespace tv = thermovis;
namespace topics = tv::transport::topics;
namespace fs = std::filesystem;

// The range array the decoders must give back field by field: frame 42, one infrared person.
tv::RangeArray known_range(std::int64_t capture_ns) {
  tv::RangeArray range;
  range.frame_seq(42);
  range.capture_time_ns(capture_ns);
  tv::TargetRange target;
  target.target_id(3);
  target.label("person");
  target.distance_m(12.5F);
  target.sigma_m(0.5F);
  target.x_m(1.5F);
  target.y_m(0.25F);
  target.z_m(12.25F);
  target.box().x(100.0F);
  target.box().y(200.0F);
  target.box().width(30.0F);
  target.box().height(80.0F);
  target.point_count(77);
  target.band(tv::BAND_INFRARED);
  range.targets().push_back(target);
  return range;
}

// The detection of that person, in the same frame.
tv::DetectionArray known_detection(const tv::RangeArray& range) {
  tv::DetectionArray detection;
  detection.frame_seq(range.frame_seq());
  detection.capture_time_ns(range.capture_time_ns());
  tv::Detection d;
  d.target_id(range.targets()[0].target_id());
  d.label("person");
  d.score(0.75F);
  d.box(range.targets()[0].box());
  detection.detections().push_back(d);
  return detection;
}

// The first `name` on PATH, or empty.
fs::path on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path == nullptr ? "" : path);
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir) / name;
    if (!dir.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return {};
}

std::string file_text(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class FoxgloveClient : public ::testing::Test {
 protected:
  // The client folder in the build tree: the package.json and script of
  // tests/integration/record/foxglove, and the packages npm installs from that package.json
  // (again only when the package.json changed).
  static void SetUpTestSuite() {
    npm_ = on_path("npm");
    node_ = on_path("node");
    if (npm_.empty() || node_.empty()) return;
    const fs::path source = tv::test::source_root() / "tests/integration/record/foxglove";
    client_ = fs::path(THERMOVIS_FOXGLOVE_CLIENT_DIR);
    fs::create_directories(client_);
    for (const char* script : {"check_recording.mjs", "check_ros2_bag.mjs"})
      fs::copy_file(source / script, client_ / script, fs::copy_options::overwrite_existing);
    const std::string wanted = file_text(source / "package.json");
    const fs::path installed = client_ / "node_modules/.installed-package.json";
    if (fs::exists(installed) && file_text(installed) == wanted) return;
    std::ofstream(client_ / "package.json") << wanted;
    ChildProcess npm({npm_.string(), "install", "--prefix", client_.string(), "--no-audit",
                      "--no-fund", "--no-save"},
                     client_ / "npm-install.log");
    const auto code = npm.wait(300s);
    if (code != 0) {
      install_error_ = "npm install in " + client_.string() + " failed:\n" + npm.log();
      return;
    }
    std::ofstream(installed) << wanted;
  }

  void SetUp() override {
    if (npm_.empty() || node_.empty()) {
      const char* ci = std::getenv("CI");
      const std::string missing =
          "npm or node is missing (Debian packages npm and nodejs; deploy/install-deps.sh "
          "installs them): the independent decoders are not run";
      if (ci != nullptr && std::string(ci) == "true") FAIL() << missing << ", and CI needs them";
      GTEST_SKIP() << missing;
    }
    ASSERT_TRUE(install_error_.empty()) << install_error_;
  }

  // Foxglove's view of `file`: check_recording.mjs's JSON.
  static nlohmann::json read_with_foxglove(const fs::path& file) {
    ChildProcess node({node_.string(), (client_ / "check_recording.mjs").string(), file.string(),
                       file.string() + ".images"},
                      file.string() + ".foxglove.log");
    const auto code = node.wait(120s);
    EXPECT_EQ(code, 0) << node.log();
    return tv::test::last_json_line(node.log());
  }

  // The independent view of the ROS 2 bag folder `dir`: check_ros2_bag.mjs's JSON.
  static nlohmann::json read_bag(const fs::path& dir) {
    ChildProcess node({node_.string(), (client_ / "check_ros2_bag.mjs").string(), dir.string()},
                      dir.string() + ".check.log");
    const auto code = node.wait(120s);
    EXPECT_EQ(code, 0) << node.log();
    return tv::test::last_json_line(node.log());
  }

  static inline fs::path npm_, node_, client_;
  static inline std::string install_error_;
};

// A ROS 2 message's header.stamp, ns since the epoch.
std::int64_t header_stamp(const nlohmann::json& message) {
  return message["header"]["stamp"]["sec"].get<std::int64_t>() * 1'000'000'000 +
         message["header"]["stamp"]["nanosec"].get<std::int64_t>();
}

// The messages of `topic` in Foxglove's view.
std::vector<nlohmann::json> messages_on(const nlohmann::json& view, const std::string& topic) {
  std::vector<nlohmann::json> out;
  for (const auto& m : view["messages"]) {
    if (m["topic"] == topic) out.push_back(m["message"]);
  }
  return out;
}

TEST_F(FoxgloveClient, EveryChannelParsesAndEveryMessageDecodesToWhatWasPublished) {
  const auto dir = tv::test::temp_dir("foxglove_client");
  const int domain = tv::test::private_domain();
  const auto participant = tv::test::loopback_participant(domain, "foxglove-test");
  const auto file = dir / "published.mcap";

  std::string all_topics;
  for (const char* t :
       {topics::kVisibleFrames, topics::kInfraredFrames, topics::kRectifiedVisible,
        topics::kRectifiedInfrared, topics::kFused, topics::kDisplay, topics::kDetections,
        topics::kMatches, topics::kRanges, topics::kTiming, topics::kHealth})
    all_topics += (all_topics.empty() ? "" : ",") + std::string(t);
  // --wait: the topics nobody publishes here are waited for that long (their channels and
  // schemas are still written); --seconds counts from then.
  ChildProcess record(
      tv::test::record_command(
          domain, {"--out", file.string(), "--topics", all_topics, "--images",
                   std::string(topics::kFused) + "," + topics::kInfraredFrames, "--image-rate",
                   "10", "--jpeg-quality", "95", "--seconds", "10", "--wait", "5"}),
      dir / "record.log");

  tv::transport::Writer<tv::RangeArray> ranges(*participant, topics::kRanges,
                                               tv::transport::event_topic_qos());
  tv::transport::Writer<tv::DetectionArray> detections(*participant, topics::kDetections,
                                                       tv::transport::event_topic_qos());
  tv::transport::Writer<tv::InfraredStereoFrame> infrared(*participant, topics::kInfraredFrames,
                                                          tv::transport::frame_topic_qos());
  ASSERT_TRUE(ranges.wait_for_readers(1, 60s)) << record.log();
  ASSERT_TRUE(detections.wait_for_readers(1, 60s)) << record.log();
  // The fused topic's QoS as the rectify-fuse writes it (recording.cpp's table).
  tv::transport::Writer<tv::GridStereoFrame> fused(
      *participant, topics::kFused,
      tv::transport::frame_topic_qos(tv::transport::kDefaultFrameDeadline, 2, 4));
  // Two readers of each frame topic and of the ranges: the CDR tap and the picture or scene tap.
  ASSERT_TRUE(ranges.wait_for_readers(2, 60s)) << record.log();
  ASSERT_TRUE(infrared.wait_for_readers(2, 60s)) << record.log();
  ASSERT_TRUE(fused.wait_for_readers(1, 60s)) << record.log();

  const tv::RangeArray range = known_range(1'700'000'000'000'000'000);
  ranges.write(range);
  detections.write(known_detection(range));

  // 14-bit counts and a colour gradient: pictures with content a codec can get wrong.
  cv::Mat counts(tv::INFRARED_HEIGHT, tv::INFRARED_WIDTH, CV_16UC1);
  cv::randu(counts, 0, 16384);
  cv::Mat colour(480, 640, CV_8UC3);
  for (int y = 0; y < colour.rows; ++y)
    for (int x = 0; x < colour.cols; ++x)
      colour.at<cv::Vec3b>(y, x) = {static_cast<std::uint8_t>(x / 3),
                                    static_cast<std::uint8_t>(y / 2),
                                    static_cast<std::uint8_t>(128)};
  // The frame topics are best-effort (as the bridge's): the same capture is sent a few times so
  // that one arrives. The pictures' rate limit keeps one picture of it.
  for (int i = 0; i < 10; ++i) {
    {
      auto frame = infrared.loan();
      frame->seq(41);
      frame->capture_time_ns(1'700'000'000'000'000'000);
      counts.copyTo(tv::node::prepare(*frame, tv::node::Eye::left, counts.size()));
      infrared.publish(std::move(frame));
    }
    {
      auto frame = fused.loan();
      frame->seq(41);
      frame->capture_time_ns(1'700'000'000'000'000'000);
      frame->eyes(tv::EYES_LEFT);
      colour.copyTo(tv::node::prepare(*frame, tv::node::Eye::left, colour.size(), CV_8UC3));
      fused.publish(std::move(frame));
    }
    std::this_thread::sleep_for(200ms);
  }

  ASSERT_EQ(record.wait(60s), 0) << record.log();
  const nlohmann::json view = read_with_foxglove(file);
  ASSERT_TRUE(view.is_object()) << "no JSON from check_recording.mjs";

  // Every recorded topic has a channel whose schema Foxglove parsed (it exits non-zero otherwise).
  std::set<std::string> channels;
  for (const auto& c : view["channels"]) channels.insert(c["topic"].get<std::string>());
  std::istringstream listed(all_topics);
  for (std::string t; std::getline(listed, t, ',');) EXPECT_EQ(channels.count(t), 1U) << t;

  const auto decoded_ranges = messages_on(view, topics::kRanges);
  ASSERT_EQ(decoded_ranges.size(), 1U) << view["channels"].dump();
  EXPECT_EQ(decoded_ranges[0]["frame_seq"], 42);
  ASSERT_EQ(decoded_ranges[0]["targets"].size(), 1U);
  const auto& t = decoded_ranges[0]["targets"][0];
  EXPECT_EQ(t["target_id"], 3);
  EXPECT_EQ(t["label"], "person");
  EXPECT_FLOAT_EQ(t["distance_m"].get<float>(), 12.5F);
  EXPECT_FLOAT_EQ(t["z_m"].get<float>(), 12.25F);
  EXPECT_EQ(t["band"], tv::BAND_INFRARED);

  const auto decoded_detections = messages_on(view, topics::kDetections);
  ASSERT_EQ(decoded_detections.size(), 1U);
  ASSERT_EQ(decoded_detections[0]["detections"].size(), 1U);
  const auto& box = decoded_detections[0]["detections"][0]["box"];
  EXPECT_FLOAT_EQ(box["x"].get<float>(), 100.0F);
  EXPECT_FLOAT_EQ(box["y"].get<float>(), 200.0F);
  EXPECT_FLOAT_EQ(box["width"].get<float>(), 30.0F);
  EXPECT_FLOAT_EQ(box["height"].get<float>(), 80.0F);
  EXPECT_FLOAT_EQ(decoded_detections[0]["detections"][0]["score"].get<float>(), 0.75F);

  const auto decoded_frames = messages_on(view, topics::kInfraredFrames);
  ASSERT_GE(decoded_frames.size(), 1U);
  EXPECT_EQ(decoded_frames[0]["seq"], 41);
  EXPECT_EQ(decoded_frames[0]["pixel_format"], tv::PIXEL_FORMAT_MONO16);
  EXPECT_EQ(decoded_frames[0]["width"], tv::INFRARED_WIDTH);
  EXPECT_EQ(decoded_frames[0]["left"]["length"], tv::INFRARED_WIDTH * tv::INFRARED_HEIGHT);

  // The pictures, as Foxglove's image panel gets them.
  const auto infrared_pictures =
      messages_on(view, std::string(topics::kInfraredFrames) + "/left/compressed");
  ASSERT_EQ(infrared_pictures.size(), 1U);
  EXPECT_EQ(infrared_pictures[0]["format"], "png");
  EXPECT_EQ(infrared_pictures[0]["frame_id"], "infrared.left");
  EXPECT_EQ(infrared_pictures[0]["timestamp"]["sec"], 1'700'000'000);
  const cv::Mat counts_back =
      cv::imread(infrared_pictures[0]["data"].get<std::string>(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(counts_back.type(), CV_16UC1);
  EXPECT_EQ(cv::norm(counts_back, counts, cv::NORM_INF), 0.0) << "the 16-bit PNG is lossless";
  const auto fused_pictures = messages_on(view, std::string(topics::kFused) + "/left/compressed");
  ASSERT_EQ(fused_pictures.size(), 1U);
  EXPECT_EQ(fused_pictures[0]["format"], "jpeg");
  EXPECT_EQ(fused_pictures[0]["frame_id"], "visible.left");
  const cv::Mat colour_back = cv::imread(fused_pictures[0]["data"].get<std::string>());
  ASSERT_EQ(colour_back.size(), colour.size());
  EXPECT_LT(cv::norm(colour_back, colour, cv::NORM_L1) / static_cast<double>(colour.total() * 3),
            2.0)
      << "mean absolute error of the quality-95 JPEG, grey levels";

  // The scene: the target as a box at its position, labelled with its distance.
  const auto scenes = messages_on(view, "thermovis/scene");
  ASSERT_EQ(scenes.size(), 1U);
  ASSERT_EQ(scenes[0]["entities"].size(), 1U);
  const auto& entity = scenes[0]["entities"][0];
  EXPECT_EQ(entity["frame_id"], "visible.left");
  const auto& position = entity["cubes"][0]["pose"]["position"];
  EXPECT_FLOAT_EQ(position["x"].get<float>(), 1.5F);
  EXPECT_FLOAT_EQ(position["y"].get<float>(), 0.25F);
  EXPECT_FLOAT_EQ(position["z"].get<float>(), 12.25F);
  EXPECT_EQ(entity["texts"][0]["text"], "person 12.5 m");

  // The rig's four cameras.
  const auto transforms = messages_on(view, "thermovis/transforms");
  ASSERT_EQ(transforms.size(), 1U);
  std::set<std::string> cameras;
  for (const auto& transform : transforms[0]["transforms"]) {
    EXPECT_EQ(transform["parent_frame_id"], "rig");
    cameras.insert(transform["child_frame_id"].get<std::string>());
  }
  EXPECT_EQ(cameras, (std::set<std::string>{"visible.left", "visible.right", "infrared.left",
                                            "infrared.right"}));
}

// A JSON integer that check_ros2_bag.mjs wrote as a number, or as a string beyond 2^53.
std::uint64_t as_u64(const nlohmann::json& value) {
  return value.is_string() ? std::stoull(value.get<std::string>()) : value.get<std::uint64_t>();
}

// The bag's channels are the bridge's ROS 2 topics (no "rt/") and types, ros2msg / cdr (the
// script exits non-zero for other encodings), with the QoS the bridge offers; its metadata.yaml
// says what the MCAP file holds.
void expect_bag_matches_its_mcap(const nlohmann::json& view) {
  EXPECT_EQ(view["profile"], "ros2");
  const std::map<std::string, std::string> expected_types{
      {"/thermovis/fused/image", "sensor_msgs/msg/Image"},
      {"/thermovis/ranges", "thermovis_msgs/msg/RangeArray"},
      {"/thermovis/detections", "thermovis_msgs/msg/DetectionArray"},
      {"/thermovis/obstacles", "thermovis_msgs/msg/ObstacleArray"}};
  std::map<std::string, std::string> channel_types;
  std::map<std::string, std::uint64_t> channel_counts;
  std::uint64_t channel_total = 0;
  for (const auto& c : view["channels"]) {
    const std::string topic = c["topic"];
    channel_types[topic] = c["schema"];
    channel_counts[topic] += c["messages"].get<std::uint64_t>();
    channel_total += c["messages"].get<std::uint64_t>();
    EXPECT_EQ(c["file"], "bag_0.mcap") << topic;
    ASSERT_EQ(c["offered_qos_profiles"].size(), 1U) << topic;
    const auto& qos = c["offered_qos_profiles"][0];
    EXPECT_EQ(qos["reliability"], 1) << topic << ": RELIABLE";
    EXPECT_EQ(qos["durability"], 2) << topic << ": VOLATILE";
    EXPECT_EQ(qos["deadline"]["sec"], 9223372036) << topic << ": no deadline";
  }
  EXPECT_EQ(channel_types, expected_types);

  // metadata.yaml: what the MCAP file holds.
  const auto& info = view["metadata"];
  EXPECT_EQ(info["version"], 5);
  EXPECT_EQ(info["storage_identifier"], "mcap");
  EXPECT_EQ(info["relative_file_paths"], nlohmann::json::array({"bag_0.mcap"}));
  ASSERT_EQ(view["files"].size(), 1U);
  const auto& counted = view["files"][0];
  EXPECT_EQ(as_u64(info["message_count"]), channel_total);
  EXPECT_EQ(as_u64(counted["messages"]), channel_total);
  EXPECT_EQ(as_u64(info["starting_time"]["nanoseconds_since_epoch"]),
            as_u64(counted["message_start_time"]));
  EXPECT_EQ(as_u64(info["duration"]["nanoseconds"]),
            as_u64(counted["message_end_time"]) - as_u64(counted["message_start_time"]));
  ASSERT_EQ(info["files"].size(), 1U);
  EXPECT_EQ(info["files"][0]["path"], "bag_0.mcap");
  EXPECT_EQ(as_u64(info["files"][0]["message_count"]), channel_total);
  EXPECT_EQ(as_u64(info["files"][0]["starting_time"]["nanoseconds_since_epoch"]),
            as_u64(counted["message_start_time"]));
  std::map<std::string, std::string> metadata_types;
  for (const auto& entry : info["topics_with_message_count"]) {
    const auto& topic = entry["topic_metadata"];
    const std::string name = topic["name"];
    metadata_types[name] = topic["type"];
    EXPECT_EQ(topic["serialization_format"], "cdr") << name;
    EXPECT_EQ(as_u64(entry["message_count"]), channel_counts[name]) << name;
    for (const auto& c : view["channels"]) {
      if (c["topic"] == name) {
        EXPECT_EQ(topic["offered_qos_profiles"], c["offered_qos_profiles"]) << name;
      }
    }
  }
  EXPECT_EQ(metadata_types, channel_types);
}

// The bridge's topics recorded into a ROS 2 bag from known samples on the pipeline's topics, read
// back by independent code: every schema parses, every message decodes to what was published
// (as thermovis-ros2 converts it), and metadata.yaml agrees with what the MCAP file holds.
TEST_F(FoxgloveClient, Ros2BagDecodesToWhatWasPublishedAndItsMetadataMatchesTheMcap) {
  const auto dir = tv::test::temp_dir("ros2_bag");
  const int domain = tv::test::private_domain();
  const auto participant = tv::test::loopback_participant(domain, "ros2-bag-test");
  const auto bag = dir / "bag";
  ChildProcess record(tv::test::record_command(domain, {"--ros2", bag.string(), "--image-rate", "2",
                                                        "--seconds", "8", "--wait", "5"}),
                      dir / "record.log");

  tv::transport::Writer<tv::RangeArray> ranges(*participant, topics::kRanges,
                                               tv::transport::event_topic_qos());
  tv::transport::Writer<tv::DetectionArray> detections(*participant, topics::kDetections,
                                                       tv::transport::event_topic_qos());
  tv::transport::Writer<tv::GridStereoFrame> fused(
      *participant, topics::kFused,
      tv::transport::frame_topic_qos(tv::transport::kDefaultFrameDeadline, 2, 4));
  ASSERT_TRUE(ranges.wait_for_readers(1, 60s)) << record.log();
  ASSERT_TRUE(detections.wait_for_readers(1, 60s)) << record.log();
  ASSERT_TRUE(fused.wait_for_readers(1, 60s)) << record.log();

  // 1'700'000'000.25 s since the epoch: the header stamp splits it into sec and nanosec.
  constexpr std::int64_t kCapture = 1'700'000'000'250'000'000;
  const tv::RangeArray range = known_range(kCapture);
  ranges.write(range);
  detections.write(known_detection(range));

  cv::Mat colour(480, 640, CV_8UC3);
  for (int y = 0; y < colour.rows; ++y)
    for (int x = 0; x < colour.cols; ++x)
      colour.at<cv::Vec3b>(y, x) = {static_cast<std::uint8_t>(x / 3),
                                    static_cast<std::uint8_t>(y / 2),
                                    static_cast<std::uint8_t>(x + y)};
  // Best-effort frames: captures 250 ms apart, each with its own time, so that some arrive; at
  // --image-rate 2 no two images in the bag are less than 500 ms apart by capture time.
  constexpr std::int64_t kFramePeriod = 250'000'000, kImagePeriod = 500'000'000;
  constexpr int kFrames = 10;
  std::set<std::int64_t> capture_times;
  for (int i = 0; i < kFrames; ++i) {
    auto frame = fused.loan();
    frame->seq(41 + i);
    frame->capture_time_ns(kCapture + i * kFramePeriod);
    frame->eyes(tv::EYES_LEFT);
    colour.copyTo(tv::node::prepare(*frame, tv::node::Eye::left, colour.size(), CV_8UC3));
    fused.publish(std::move(frame));
    capture_times.insert(kCapture + i * kFramePeriod);
    std::this_thread::sleep_for(200ms);
  }

  ASSERT_EQ(record.wait(60s), 0) << record.log();
  const nlohmann::json view = read_bag(bag);
  ASSERT_TRUE(view.is_object()) << "no JSON from check_ros2_bag.mjs";

  expect_bag_matches_its_mcap(view);

  // The messages, as thermovis-ros2 publishes them.
  const auto decoded_ranges = messages_on(view, "/thermovis/ranges");
  ASSERT_EQ(decoded_ranges.size(), 1U) << view["channels"].dump();
  const auto& r = decoded_ranges[0];
  EXPECT_EQ(r["header"]["frame_id"], "thermovis_visible_left_optical");
  EXPECT_EQ(r["header"]["stamp"]["sec"], 1'700'000'000);
  EXPECT_EQ(r["header"]["stamp"]["nanosec"], 250'000'000);
  EXPECT_EQ(r["frame_seq"], 42);
  ASSERT_EQ(r["targets"].size(), 1U);
  const auto& t = r["targets"][0];
  EXPECT_EQ(t["target_id"], 3);
  EXPECT_EQ(t["label"], "person");
  EXPECT_FLOAT_EQ(t["distance_m"].get<float>(), 12.5F);
  EXPECT_FLOAT_EQ(t["sigma_m"].get<float>(), 0.5F);
  EXPECT_FLOAT_EQ(t["x_m"].get<float>(), 1.5F);
  EXPECT_FLOAT_EQ(t["z_m"].get<float>(), 12.25F);
  EXPECT_FLOAT_EQ(t["box"]["x"].get<float>(), 100.0F);
  EXPECT_FLOAT_EQ(t["box"]["height"].get<float>(), 80.0F);
  EXPECT_EQ(t["point_count"], 77);
  EXPECT_EQ(t["band"], tv::BAND_INFRARED);

  const auto decoded_detections = messages_on(view, "/thermovis/detections");
  ASSERT_EQ(decoded_detections.size(), 1U);
  EXPECT_EQ(decoded_detections[0]["header"]["frame_id"], "thermovis_rectified_left");
  EXPECT_EQ(decoded_detections[0]["frame_seq"], 42);
  ASSERT_EQ(decoded_detections[0]["detections"].size(), 1U);
  const auto& detected = decoded_detections[0]["detections"][0];
  EXPECT_FLOAT_EQ(detected["score"].get<float>(), 0.75F);
  EXPECT_FLOAT_EQ(detected["box"]["x"].get<float>(), 100.0F);
  EXPECT_FLOAT_EQ(detected["box"]["y"].get<float>(), 200.0F);
  EXPECT_FLOAT_EQ(detected["box"]["width"].get<float>(), 30.0F);
  EXPECT_FLOAT_EQ(detected["box"]["height"].get<float>(), 80.0F);

  const auto images = messages_on(view, "/thermovis/fused/image");
  ASSERT_GE(images.size(), 1U);
  EXPECT_LE(images.size(),
            static_cast<std::size_t>((kFrames - 1) * kFramePeriod / kImagePeriod + 1))
      << "at most 2 images a second of capture time";
  std::optional<std::int64_t> previous;
  for (const auto& image : images) {
    const std::int64_t stamp = header_stamp(image);
    EXPECT_EQ(capture_times.count(stamp), 1U) << "an image stamped " << stamp;
    if (previous) {
      EXPECT_GE(stamp - *previous, kImagePeriod) << "an image stamped " << stamp;
    }
    previous = stamp;
    EXPECT_EQ(image["header"]["frame_id"], "thermovis_rectified_left");
    EXPECT_EQ(image["encoding"], "bgr8");
    EXPECT_EQ(image["width"], 640);
    EXPECT_EQ(image["height"], 480);
    EXPECT_EQ(image["step"], 640 * 3);
    EXPECT_EQ(image["is_bigendian"], 0);
    EXPECT_EQ(image["data"]["length"], 640 * 480 * 3);
    std::vector<int> head;
    for (int i = 0; i < 16; ++i) head.push_back(colour.data[i]);
    EXPECT_EQ(image["data"]["head"], nlohmann::json(head));
  }
}

// A short run of the real pipeline recorded as a ROS 2 bag: every range array and image in it
// is one the pipeline published on its own topics, converted as thermovis-ros2 converts it.
TEST_F(FoxgloveClient, Ros2BagOfAPipelineRunHoldsWhatThePipelinePublished) {
  const auto dir = tv::test::temp_dir("ros2_bag_pipeline");
  const int domain = tv::test::private_domain();
  ChildProcess supervisor(tv::test::supervisor_command(dir, domain), dir / "pipeline.log");
  const auto participant = tv::test::loopback_participant(domain, "ros2-bag-pipeline-test");
  tv::transport::Reader<tv::RangeArray> ranges(*participant, topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  tv::transport::Reader<tv::GridStereoFrame> fused(
      *participant, topics::kFused,
      tv::transport::observer_qos(
          tv::transport::frame_topic_qos(tv::transport::kDefaultFrameDeadline, 2, 4)));
  struct Published {
    std::int64_t capture_ns = 0;
    std::vector<std::array<float, 5>> targets;  // distance_m, box x, y, width, height
  };
  std::map<std::uint64_t, Published> published;  // by frame_seq
  std::set<std::int64_t> fused_captures;
  const auto take = [&] {
    auto arrays = ranges.take();
    for (std::size_t i = 0; i < arrays.size(); ++i) {
      Published& p = published[arrays[i].frame_seq()];
      p.capture_ns = arrays[i].capture_time_ns();
      p.targets.clear();
      for (const tv::TargetRange& t : arrays[i].targets())
        p.targets.push_back(
            {t.distance_m(), t.box().x(), t.box().y(), t.box().width(), t.box().height()});
    }
    auto frames = fused.take();
    for (std::size_t i = 0; i < frames.size(); ++i)
      fused_captures.insert(frames[i].capture_time_ns());
  };
  ASSERT_TRUE(tv::test::receive<tv::RangeArray>(
      ranges, [](const tv::RangeArray& a) { return !a.targets().empty(); }, 120s))
      << supervisor.log() << tv::test::service_logs(dir);

  const auto bag = dir / "bag";
  ChildProcess record(
      tv::test::record_command(domain, {"--ros2", bag.string(), "--seconds", "5", "--wait", "60"}),
      dir / "record.log");
  const auto until = std::chrono::steady_clock::now() + 120s;
  while (!record.poll() && std::chrono::steady_clock::now() < until) {
    fused.wait_for_data(20ms);
    take();
  }
  ASSERT_EQ(record.wait(10s), 0) << record.log();
  std::cout << "record --ros2: " << tv::test::last_json_line(record.log()).dump() << "\n";
  take();
  supervisor.signal(SIGTERM);
  EXPECT_EQ(supervisor.wait(60s), 0) << supervisor.log();

  const nlohmann::json view = read_bag(bag);
  ASSERT_TRUE(view.is_object()) << "no JSON from check_ros2_bag.mjs";
  expect_bag_matches_its_mcap(view);

  const auto decoded_ranges = messages_on(view, "/thermovis/ranges");
  ASSERT_GE(decoded_ranges.size(), 5U) << record.log();
  std::size_t with_targets = 0;
  for (const auto& r : decoded_ranges) {
    const auto seq = r["frame_seq"].get<std::uint64_t>();
    const auto live = published.find(seq);
    ASSERT_NE(live, published.end()) << "frame " << seq << " is not one the pipeline published";
    EXPECT_EQ(header_stamp(r), live->second.capture_ns) << "frame " << seq;
    ASSERT_EQ(r["targets"].size(), live->second.targets.size()) << "frame " << seq;
    for (std::size_t i = 0; i < live->second.targets.size(); ++i) {
      const auto& t = r["targets"][i];
      const auto& want = live->second.targets[i];
      EXPECT_FLOAT_EQ(t["distance_m"].get<float>(), want[0]) << "frame " << seq;
      EXPECT_FLOAT_EQ(t["box"]["x"].get<float>(), want[1]) << "frame " << seq;
      EXPECT_FLOAT_EQ(t["box"]["y"].get<float>(), want[2]) << "frame " << seq;
      EXPECT_FLOAT_EQ(t["box"]["width"].get<float>(), want[3]) << "frame " << seq;
      EXPECT_FLOAT_EQ(t["box"]["height"].get<float>(), want[4]) << "frame " << seq;
    }
    if (!live->second.targets.empty()) ++with_targets;
  }
  EXPECT_GT(with_targets, 0U) << "the simulated scene's targets are ranged";

  // The images' rate leaves the ranges alone: every range array the pipeline published between the
  // bag's first and last is in it, but for those the recorder says it missed.
  std::set<std::uint64_t> in_bag;
  for (const auto& r : decoded_ranges) in_bag.insert(r["frame_seq"].get<std::uint64_t>());
  std::size_t absent = 0;
  for (const auto& [seq, p] : published)
    absent += seq > *in_bag.begin() && seq < *in_bag.rbegin() && in_bag.count(seq) == 0;
  const auto summary = tv::test::last_json_line(record.log());
  EXPECT_LE(absent, summary["topics"]["/thermovis/ranges"]["missed"].get<std::size_t>())
      << "range arrays published during the recording and not in the bag";

  // Images: stamped with the capture time of a fused frame. This test's own reader of the 50 Hz
  // frames (KEEP_LAST 2) can miss one on a loaded machine, and the ranges skip the frames the
  // services dropped: nine in ten stamps, not every one, must be among those it saw.
  const auto images = messages_on(view, "/thermovis/fused/image");
  ASSERT_GE(images.size(), 4U) << record.log();
  std::set<std::int64_t> seen = fused_captures;
  for (const auto& [seq, p] : published) seen.insert(p.capture_ns);
  std::size_t known = 0;
  std::optional<std::int64_t> previous;
  for (const auto& image : images) {
    const std::int64_t stamp = header_stamp(image);
    known += seen.count(stamp);
    // The default --image-rate, 2 a second by capture time.
    if (previous) {
      EXPECT_GE(stamp - *previous, 500'000'000) << "an image stamped " << stamp;
    }
    previous = stamp;
    EXPECT_GT(image["width"].get<int>(), 0);
    EXPECT_EQ(image["data"]["length"].get<int>(),
              image["step"].get<int>() * image["height"].get<int>());
  }
  EXPECT_GE(known * 10, images.size() * 9)
      << known << " of " << images.size()
      << " image stamps are capture times the pipeline published";
}

// A --ros2 target that is not a new or empty folder fails before anything is recorded, naming it.
TEST(RecordRos2Bag, AFileOrANonEmptyFolderIsRefusedNamingIt) {
  const auto dir = tv::test::temp_dir("ros2_bag_refused");
  const fs::path full = dir / "full";
  fs::create_directories(full);
  std::ofstream(full / "metadata.yaml") << "rosbag2_bagfile_information: {}\n";
  const fs::path file = dir / "a_file";
  std::ofstream(file) << "not a folder\n";
  const struct {
    fs::path target;
    std::string why;
  } cases[] = {{full, "exists and is not empty"}, {file, "is a file, not a folder"}};
  for (const auto& c : cases) {
    ChildProcess record(
        {(tv::test::bin_dir() / "thermovis").string(), "record", "--ros2", c.target.string(),
         "--seconds", "1", "--wait", "0", "--domain", std::to_string(tv::test::private_domain()),
         "--profile", tv::transport::kLoopbackProfile},
        dir / (c.target.filename().string() + ".log"));
    EXPECT_NE(record.wait(60s), 0) << record.log();
    EXPECT_NE(record.log().find("'" + c.target.string() + "' " + c.why), std::string::npos)
        << record.log();
  }
  // Nothing was added to either.
  EXPECT_EQ(std::distance(fs::directory_iterator(full), fs::directory_iterator()), 1);
  EXPECT_TRUE(fs::is_regular_file(file));
}

}  // namespace
