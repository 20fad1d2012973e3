// Vendor interoperability: a Fast DDS writer (transport_peer) publishes thermovis::RangeArray
// on thermovis/ranges and thermovis-tap, a Cyclone DDS client built from the same IDL with
// idlc, records what it receives. Both sides stay on 127.0.0.1 (deploy/dds/loopback.xml and
// cyclonedds-loopback.xml). The test checks the recorded samples field by field.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "range_pattern.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/frames.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::ChildProcess;

using thermovis::test::private_domain;

TEST(ThermovisTap, RecordsRangesFromFastDdsWriter) {
  const auto dir = thermovis::test::temp_dir("tap");
  const auto record = dir / "ranges.jsonl";
  const std::string domain = std::to_string(private_domain());
  const std::string cyclone_config =
      "file://" + (thermovis::test::source_root() / "deploy/dds/cyclonedds-loopback.xml").string();
  // The writer sends 40 samples, 50 ms apart, or stops early once the tap has left (Cyclone's
  // departure reaches Fast DDS only at lease expiry, hence the fixed count).
  const int wanted = 5;

  ChildProcess tap(
      {(thermovis::test::bin_dir() / "thermovis-tap").string(), "thermovis/ranges", "--domain",
       domain, "--count", std::to_string(wanted), "--record", record.string()},
      dir / "tap.log", {{"CYCLONEDDS_URI", cyclone_config}});
  ChildProcess publisher(
      {(thermovis::test::bin_dir() / "transport_peer").string(), "publish-ranges", "--domain",
       domain, "--count", "40", "--period-ms", "50", "--timeout-s", "60"},
      dir / "pub.log");
  const auto tap_exit = tap.wait(90s);
  const auto pub_exit = publisher.wait(30s);
  ASSERT_EQ(tap_exit, 0) << "thermovis-tap log:\n" << tap.log();
  ASSERT_EQ(pub_exit, 0) << "publisher log:\n" << publisher.log();

  std::ifstream in(record);
  std::vector<nlohmann::json> samples;
  for (std::string line; std::getline(in, line);) samples.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(samples.size(), static_cast<std::size_t>(wanted));

  // A reliable stream: consecutive frames once the tap has matched the writer.
  const auto first = samples.front()["frame_seq"].get<std::uint64_t>();
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    const std::uint64_t seq = first + i;
    SCOPED_TRACE("frame_seq " + std::to_string(seq));
    ASSERT_EQ(s["frame_seq"].get<std::uint64_t>(), seq);
    EXPECT_EQ(s["capture_time_ns"].get<std::int64_t>(),
              thermovis::test::expected_capture_time_ns(seq));
    ASSERT_EQ(s["targets"].size(), static_cast<std::size_t>(thermovis::test::kTargetsPerFrame));
    for (int t = 0; t < thermovis::test::kTargetsPerFrame; ++t) {
      const auto e = thermovis::test::expected_target(seq, t);
      const auto& got = s["targets"][static_cast<std::size_t>(t)];
      EXPECT_EQ(got["target_id"].get<std::uint32_t>(), e.target_id);
      EXPECT_EQ(got["label"].get<std::string>(), e.label);
      EXPECT_FLOAT_EQ(got["distance_m"].get<float>(), e.distance_m);
      EXPECT_FLOAT_EQ(got["sigma_m"].get<float>(), e.sigma_m);
      EXPECT_FLOAT_EQ(got["x_m"].get<float>(), e.x_m);
      EXPECT_FLOAT_EQ(got["y_m"].get<float>(), e.y_m);
      EXPECT_FLOAT_EQ(got["z_m"].get<float>(), e.z_m);
      EXPECT_FLOAT_EQ(got["box"]["x"].get<float>(), e.box_x);
      EXPECT_FLOAT_EQ(got["box"]["y"].get<float>(), e.box_y);
      EXPECT_FLOAT_EQ(got["box"]["width"].get<float>(), e.box_width);
      EXPECT_FLOAT_EQ(got["box"]["height"].get<float>(), e.box_height);
      EXPECT_EQ(got["point_count"].get<std::uint32_t>(), e.point_count);
    }
  }
  std::filesystem::remove_all(dir);
}

TEST(ThermovisTap, StopsCleanlyOnSigterm) {
  const auto dir = thermovis::test::temp_dir("tap-stop");
  const auto record = dir / "health.jsonl";
  const std::string cyclone_config =
      "file://" + (thermovis::test::source_root() / "deploy/dds/cyclonedds-loopback.xml").string();
  ChildProcess tap({(thermovis::test::bin_dir() / "thermovis-tap").string(), "thermovis/health",
                    "--domain", std::to_string(private_domain()), "--record", record.string()},
                   dir / "tap.log", {{"CYCLONEDDS_URI", cyclone_config}});
  // The record file is opened before the DDS entities: once it exists the tap is running.
  const auto give_up = std::chrono::steady_clock::now() + 30s;
  while (!std::filesystem::exists(record) && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(std::filesystem::exists(record)) << tap.log();
  tap.signal(SIGTERM);
  EXPECT_EQ(tap.wait(10s), 0) << tap.log();
  std::filesystem::remove_all(dir);
}

TEST(ThermovisTap, UnknownTopicIsAnError) {
  const auto dir = thermovis::test::temp_dir("tap-bad");
  ChildProcess tap({(thermovis::test::bin_dir() / "thermovis-tap").string(), "thermovis/nope"},
                   dir / "tap.log");
  EXPECT_EQ(tap.wait(10s), 1);
  EXPECT_NE(tap.log().find("unknown topic 'thermovis/nope'"), std::string::npos) << tap.log();
  std::filesystem::remove_all(dir);
}

// Another vendor reads frames too: the rectified visible topic's packed twin, written by a Fast
// DDS FrameWriter (as rectify-fuse writes it), reaches thermovis-tap (Cyclone DDS) with its
// header and exactly its image's bytes (their hash compared with the writer's).
TEST(ThermovisTap, RecordsPackedFramesFromAFastDdsFrameWriter) {
  namespace tt = thermovis::transport;
  const auto dir = thermovis::test::temp_dir("tap-frames");
  const auto record = dir / "frames.jsonl";
  const int domain = private_domain();
  const std::string cyclone_config =
      "file://" + (thermovis::test::source_root() / "deploy/dds/cyclonedds-loopback.xml").string();
  tt::ParticipantConfig config;
  config.domain_id = domain;
  config.profile = tt::kLoopbackProfile;
  config.profiles_file = tt::shipped_profile_file(config.profile);
  config.name = "tap-frame-writer";
  tt::Participant participant(config);
  tt::FrameWriter<thermovis::GridStereoFrame> writer(participant, tt::topics::kRectifiedVisible,
                                                     tt::frame_topic_qos(0ns));
  const int wanted = 3;
  ChildProcess tap(
      {(thermovis::test::bin_dir() / "thermovis-tap").string(),
       std::string(tt::topics::kRectifiedVisible) + "/packed", "--domain", std::to_string(domain),
       "--count", std::to_string(wanted), "--record", record.string()},
      dir / "tap.log", {{"CYCLONEDDS_URI", cyclone_config}});
  // The frame of `seq`: the pipeline grid's visible pair (MONO8), bytes following seq.
  const auto fill = [](thermovis::GridStereoFrame& f, std::uint64_t seq) {
    f.seq(seq);
    f.capture_time_ns(1000 + static_cast<std::int64_t>(seq));
    f.stamps(thermovis::PipelineStamps{});
    f.pixel_format(thermovis::PIXEL_FORMAT_MONO8);
    f.width(936);
    f.height(566);
    f.step(936);
    f.eyes(thermovis::EYES_BOTH);
    f.geometry_id(5);
    for (std::size_t i = 0; i < 936u * 566u; ++i) {
      f.left()[i] = static_cast<std::uint8_t>(i * 7 + seq);
      f.right()[i] = static_cast<std::uint8_t>(i * 11 + seq);
    }
  };
  const auto fnv1a = [](const std::uint8_t* bytes, std::size_t length) {
    std::uint64_t h = 1469598103934665603ull;
    for (std::size_t i = 0; i < length; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
    return h;
  };
  // Frames every 50 ms until the tap has its count (Cyclone's reader matches the twin first).
  std::optional<int> tap_exit;
  for (std::uint64_t seq = 1; seq <= 400 && !tap_exit; ++seq) {
    auto loan = writer.loan();
    fill(*loan, seq);
    writer.publish(std::move(loan));
    std::this_thread::sleep_for(50ms);
    tap_exit = tap.poll();
  }
  ASSERT_TRUE(tap_exit.has_value()) << "the tap got no frames in 20 s:\n" << tap.log();
  ASSERT_EQ(*tap_exit, 0) << tap.log();
  EXPECT_GE(writer.packed_counters().samples, static_cast<std::uint64_t>(wanted));

  std::ifstream in(record);
  std::vector<nlohmann::json> samples;
  for (std::string line; std::getline(in, line);) samples.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(samples.size(), static_cast<std::size_t>(wanted));
  auto expected = std::make_unique<thermovis::GridStereoFrame>();
  for (const auto& s : samples) {
    const auto seq = s["seq"].get<std::uint64_t>();
    SCOPED_TRACE("seq " + std::to_string(seq));
    fill(*expected, seq);
    EXPECT_EQ(s["width"].get<int>(), 936);
    EXPECT_EQ(s["height"].get<int>(), 566);
    EXPECT_EQ(s["step"].get<int>(), 936);
    EXPECT_EQ(s["geometry_id"].get<int>(), 5);
    EXPECT_EQ(s["capture_time_ns"].get<std::int64_t>(), 1000 + static_cast<std::int64_t>(seq));
    EXPECT_EQ(s["left_bytes"].get<std::size_t>(), 936u * 566u);
    EXPECT_EQ(s["right_bytes"].get<std::size_t>(), 936u * 566u);
    EXPECT_EQ(s["left_fnv1a"].get<std::uint64_t>(), fnv1a(expected->left().data(), 936u * 566u));
    EXPECT_EQ(s["right_fnv1a"].get<std::uint64_t>(), fnv1a(expected->right().data(), 936u * 566u));
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
