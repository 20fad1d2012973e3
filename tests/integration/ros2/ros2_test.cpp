// thermovis-ros2 as a ROS 2 node sees it. The test feeds known fused frames and range arrays into
// the pipeline's topics (Fast DDS, loopback profile, a private domain); thermovis-ros2
// republishes them on rt/thermovis/...; a Cyclone DDS participant whose types idlc generated from
// the ROS 2 wire IDL (idl/ros2/) subscribes like an rclcpp node would and checks every field and
// every pixel. Before any ROS reader exists, the bridge must publish nothing and convert nothing.
#include <dds/dds.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "ros2/sensor_msgs.h"
#include "ros2/thermovis_msgs.h"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/obstacles.h"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::ChildProcess;
namespace tv = thermovis;
namespace topics = tv::transport::topics;

std::unique_ptr<tv::transport::Participant> loopback_participant(int domain) {
  tv::transport::ParticipantConfig pc;
  pc.domain_id = domain;
  pc.profile = tv::transport::kLoopbackProfile;
  pc.name = "ros2-test";
  return std::make_unique<tv::transport::Participant>(pc);
}

// What the test published for one capture.
struct Fed {
  std::int64_t capture_ns = 0;
  std::string encoding;
  cv::Mat left;  // the pixels (a copy)
  tv::RangeArray ranges;
  tv::ObstacleArray obstacles;
};

// A subscriber of the ROS 2 side: Cyclone DDS, reliable KEEP_LAST 16 (an rclcpp subscription
// with a deeper queue).
class CycloneSide {
 public:
  explicit CycloneSide(int domain) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain), nullptr, nullptr);
    if (participant_ < 0) throw std::runtime_error(dds_strretcode(participant_));
    dds_qos_t* qos = dds_create_qos();
    dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 16);
    const dds_entity_t image_topic = dds_create_topic(
        participant_, &sensor_msgs_msg_dds__Image__desc, topics::kRos2FusedImage, nullptr, nullptr);
    const dds_entity_t ranges_topic =
        dds_create_topic(participant_, &thermovis_msgs_msg_dds__RangeArray__desc,
                         topics::kRos2Ranges, nullptr, nullptr);
    const dds_entity_t obstacles_topic =
        dds_create_topic(participant_, &thermovis_msgs_msg_dds__ObstacleArray__desc,
                         topics::kRos2Obstacles, nullptr, nullptr);
    images = dds_create_reader(participant_, image_topic, qos, nullptr);
    ranges = dds_create_reader(participant_, ranges_topic, qos, nullptr);
    obstacles = dds_create_reader(participant_, obstacles_topic, qos, nullptr);
    dds_delete_qos(qos);
    if (images < 0 || ranges < 0 || obstacles < 0)
      throw std::runtime_error("cannot create Cyclone readers");
  }
  ~CycloneSide() { dds_delete(participant_); }
  CycloneSide(const CycloneSide&) = delete;
  CycloneSide& operator=(const CycloneSide&) = delete;

  static bool matched(dds_entity_t reader) {
    dds_subscription_matched_status_t status;
    return dds_get_subscription_matched_status(reader, &status) == DDS_RETCODE_OK &&
           status.current_count > 0;
  }

  // Calls `each` for every valid sample available on `reader`.
  template <class T, class F>
  static void take(dds_entity_t reader, F&& each) {
    void* samples[8] = {};
    dds_sample_info_t infos[8];
    const dds_return_t n = dds_take(reader, samples, infos, 8, 8);
    for (dds_return_t i = 0; i < n; ++i)
      if (infos[i].valid_data) each(*static_cast<const T*>(samples[i]));
    if (n > 0) dds_return_loan(reader, samples, n);
  }

  dds_entity_t images = 0, ranges = 0, obstacles = 0;

 private:
  dds_entity_t participant_ = 0;
};

std::int64_t ns_of(const builtin_interfaces_msg_dds__Time_& t) {
  return static_cast<std::int64_t>(t.sec_) * 1'000'000'000 + t.nanosec_;
}

tv::Box2D box(float x, float y, float w, float h) {
  tv::Box2D b;
  b.x(x);
  b.y(y);
  b.width(w);
  b.height(h);
  return b;
}

class Ros2Bridge : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tv::test::temp_dir("ros2");
    domain_ = tv::test::private_domain();
    // Cyclone reads its configuration when its first participant is created.
    ::setenv("CYCLONEDDS_URI",
             ("file://" + (tv::test::source_root() / "deploy/dds/cyclonedds-loopback.xml").string())
                 .c_str(),
             1);
    participant_ = loopback_participant(domain_);
    fused_ = std::make_unique<tv::transport::Writer<tv::GridStereoFrame>>(
        *participant_, topics::kFused, tv::transport::frame_topic_qos(0ns, 2, 2));
    ranges_ = std::make_unique<tv::transport::Writer<tv::RangeArray>>(
        *participant_, topics::kRanges, tv::transport::event_topic_qos());
    obstacles_ = std::make_unique<tv::transport::Writer<tv::ObstacleArray>>(
        *participant_, topics::kObstacles, tv::transport::event_topic_qos());
    health_ = std::make_unique<tv::transport::Reader<tv::Health>>(*participant_, topics::kHealth,
                                                                  tv::transport::state_topic_qos());
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  ChildProcess start_bridge() {
    return ChildProcess({(tv::test::bin_dir() / "thermovis-ros2").string(), "--domain",
                         std::to_string(domain_), "--profile", tv::transport::kLoopbackProfile,
                         "--ros-profile", tv::transport::kLoopbackProfile},
                        dir_ / "ros2.log");
  }

  // Publishes capture `seq`: a seeded random left image (BGR8 or MONO8, 933 x 541: an odd row
  // length) and a range array of two targets. `corrupt`: an unknown pixel format instead.
  void feed(std::uint64_t seq, bool mono, bool corrupt = false) {
    Fed fed;
    fed.capture_ns = 1'700'000'000'000'000'000LL + static_cast<std::int64_t>(seq) * 20'000'123;
    auto loan = fused_->loan();
    tv::GridStereoFrame& frame = *loan;
    cv::Mat left =
        tv::node::prepare(frame, tv::node::Eye::left, cv::Size(933, 541), mono ? CV_8UC1 : CV_8UC3);
    cv::RNG rng(seq);
    rng.fill(left, cv::RNG::UNIFORM, 0, 256);
    frame.seq(seq);
    frame.capture_time_ns(fed.capture_ns);
    tv::transport::clear_stamps(frame.stamps());
    frame.eyes(tv::EYES_LEFT);
    frame.geometry_id(0);
    if (corrupt) frame.pixel_format(77);
    fed.left = left.clone();
    fed.encoding = mono ? "mono8" : "bgr8";
    fused_->publish(std::move(loan));
    if (corrupt) return;

    tv::RangeArray& r = fed.ranges;
    r.frame_seq(seq);
    r.capture_time_ns(fed.capture_ns);
    for (std::uint32_t i = 0; i < 2; ++i) {
      tv::TargetRange t;
      t.target_id(i + 1);
      t.label(i == 0 ? "person" : "vehicle");
      t.distance_m(5.5f + static_cast<float>(seq % 7) + i);
      t.sigma_m(0.125f * (i + 1));
      t.x_m(-1.5f + i);
      t.y_m(0.25f);
      t.z_m(t.distance_m() - 0.5f);
      t.box(box(100.f + i * 200, 80.f, 40.f + i, 90.f));
      t.point_count(12 + i);
      t.band(i == 0 ? tv::BAND_VISIBLE : tv::BAND_INFRARED);
      r.targets().push_back(t);
    }
    tv::transport::clear_stamps(r.stamps());
    tv::transport::append_stamp(r.stamps(), tv::STAGE_RANGE, fed.capture_ns + 1'000'000,
                                fed.capture_ns + 4'000'000);
    ranges_->write(r);

    // One ranged person and one obstacle, and the free space of a 5-column grid.
    tv::ObstacleArray& o = fed.obstacles;
    o.frame_seq(seq);
    o.capture_time_ns(fed.capture_ns);
    o.visible_ground(tv::GROUND_OK);
    o.infrared_ground(tv::GROUND_NO_GROUND);
    o.ground_normal({0.0f, 0.99f, 0.141f});
    o.ground_height_m(1.4f);
    for (std::uint32_t i = 0; i < 2; ++i) {
      tv::Obstacle b;
      b.obstacle_id(i);
      b.label(i == 0 ? "person" : "obstacle");
      b.has_target(i == 0);
      b.target_id(i == 0 ? 1 : 0);
      b.distance_m(5.0f + static_cast<float>(seq % 5) + 3 * i);
      b.sigma_m(0.1f + i);
      b.x_m(-1.0f + i);
      b.y_m(0.5f);
      b.z_m(b.distance_m());
      b.width_m(0.6f + i);
      b.height_m(1.7f);
      b.depth_m(0.25f * i);
      b.box(box(100.f + i * 200, 80.f, 40.f, 90.f + i));
      b.band(i == 0 ? tv::BAND_FUSED : tv::BAND_VISIBLE);
      b.stixels(4 + i);
      o.obstacles().push_back(b);
    }
    o.free_space_m({60.0f, 12.5f, std::numeric_limits<float>::quiet_NaN(), 8.0f, 60.0f});
    o.free_space_row({300.5f, 320.0f, std::numeric_limits<float>::quiet_NaN(), 340.25f, 300.5f});
    o.max_distance_m(60.0f);
    tv::transport::clear_stamps(o.stamps());
    tv::transport::append_stamp(o.stamps(), tv::STAGE_OBSTACLES, fed.capture_ns + 1'000'000,
                                fed.capture_ns + 6'000'000);
    obstacles_->write(o);
    fed_[seq] = std::move(fed);
  }

  // The bridge's last health once `ok` holds for it (or the last seen, on timeout).
  std::optional<tv::Health> wait_health(const std::function<bool(const tv::Health&)>& ok,
                                        std::chrono::milliseconds timeout) {
    std::optional<tv::Health> last;
    const auto until = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < until) {
      health_->wait_for_data(100ms);
      auto samples = health_->take();
      for (std::size_t i = 0; i < samples.size(); ++i)
        if (samples[i].service().to_string() == "thermovis-ros2") last = samples[i];
      if (last && ok(*last)) return last;
    }
    return last;
  }

  static std::uint64_t samples_of(const tv::Health& h, const std::string& topic) {
    for (const auto& t : h.topics())
      if (t.topic().to_string() == topic) return t.samples();
    return ~0ull;  // not listed: fails every check below
  }

  std::filesystem::path dir_;
  int domain_ = 0;
  std::unique_ptr<tv::transport::Participant> participant_;
  std::unique_ptr<tv::transport::Writer<tv::GridStereoFrame>> fused_;
  std::unique_ptr<tv::transport::Writer<tv::RangeArray>> ranges_;
  std::unique_ptr<tv::transport::Writer<tv::ObstacleArray>> obstacles_;
  std::unique_ptr<tv::transport::Reader<tv::Health>> health_;
  std::map<std::uint64_t, Fed> fed_;
};

TEST_F(Ros2Bridge, RepublishesFusedImageRangesAndObstaclesForRos2OnlyWhileSubscribed) {
  ChildProcess bridge = start_bridge();
  ASSERT_TRUE(fused_->wait_for_readers(1, 30000ms)) << bridge.log();
  ASSERT_TRUE(ranges_->wait_for_readers(1, 30000ms)) << bridge.log();
  ASSERT_TRUE(obstacles_->wait_for_readers(1, 30000ms)) << bridge.log();

  // No ROS 2 subscriber: the inputs arrive, nothing is converted or written. Frames are fed
  // until the bridge has taken ten of each (a frame reader keeps the newest two: on a loaded
  // machine the bridge may not take every one of a burst).
  const auto took_ten = [](const tv::Health& h) {
    return samples_of(h, topics::kFused) >= 10 && samples_of(h, topics::kRanges) >= 10;
  };
  std::optional<tv::Health> idle;
  const auto feeding_ends = std::chrono::steady_clock::now() + 30s;
  for (std::uint64_t seq = 1; std::chrono::steady_clock::now() < feeding_ends; ++seq) {
    if (seq < 90) feed(seq, seq % 2 == 0);  // the phase below starts at 100
    idle = wait_health(took_ten, 50ms);
    if (idle && took_ten(*idle)) break;
  }
  ASSERT_TRUE(idle && samples_of(*idle, topics::kFused) >= 10) << bridge.log();
  EXPECT_EQ(idle->frames_processed(), 0u) << "images converted without a subscriber";
  EXPECT_EQ(samples_of(*idle, topics::kRos2FusedImage), 0u);
  EXPECT_EQ(samples_of(*idle, topics::kRos2Ranges), 0u);
  EXPECT_EQ(samples_of(*idle, topics::kRos2Detections), 0u);
  EXPECT_EQ(samples_of(*idle, topics::kRos2Obstacles), 0u);

  // A ROS 2 node subscribes.
  CycloneSide ros(domain_);
  const auto match_until = std::chrono::steady_clock::now() + 30s;
  const auto all_matched = [&] {
    return CycloneSide::matched(ros.images) && CycloneSide::matched(ros.ranges) &&
           CycloneSide::matched(ros.obstacles);
  };
  while (std::chrono::steady_clock::now() < match_until && !all_matched())
    std::this_thread::sleep_for(20ms);
  ASSERT_TRUE(all_matched()) << bridge.log();

  // Captures 100.. alternate bgr8 and mono8; one corrupt frame in between.
  std::map<std::int64_t, std::uint64_t> seq_of_capture;
  int images = 0, bgr = 0, mono = 0, ranges = 0, obstacles = 0;
  std::uint64_t seq = 100;
  const auto until = std::chrono::steady_clock::now() + 60s;
  while (std::chrono::steady_clock::now() < until &&
         (bgr < 4 || mono < 4 || ranges < 8 || obstacles < 8)) {
    if (seq == 103) {
      feed(seq++, false, true);
      // Nothing newer until the bridge has taken it (it converts only the newest frame queued).
      ASSERT_TRUE(wait_health([](const tv::Health& h) { return h.errors() >= 1; }, 30s))
          << bridge.log();
    } else {
      feed(seq, seq % 2 == 1);
      seq_of_capture[fed_[seq].capture_ns] = seq;
      ++seq;
    }
    std::this_thread::sleep_for(50ms);
    CycloneSide::take<sensor_msgs_msg_dds__Image_>(ros.images, [&](const auto& image) {
      const auto it = seq_of_capture.find(ns_of(image.header_.stamp_));
      ASSERT_NE(it, seq_of_capture.end()) << "an image whose stamp is no capture's";
      const Fed& fed = fed_.at(it->second);
      SCOPED_TRACE("image of capture " + std::to_string(it->second));
      EXPECT_STREQ(image.header_.frame_id_, "thermovis_rectified_left");
      EXPECT_EQ(image.width_, static_cast<std::uint32_t>(fed.left.cols));
      EXPECT_EQ(image.height_, static_cast<std::uint32_t>(fed.left.rows));
      EXPECT_EQ(std::string(image.encoding_), fed.encoding);
      EXPECT_EQ(image.is_bigendian_, 0);
      EXPECT_EQ(image.step_, static_cast<std::uint32_t>(fed.left.cols * fed.left.channels()));
      ASSERT_EQ(image.data_._length, static_cast<std::uint32_t>(image.step_ * image.height_));
      EXPECT_EQ(std::memcmp(image.data_._buffer, fed.left.data, image.data_._length), 0)
          << "pixels differ";
      ++images;
      (fed.encoding == "mono8" ? mono : bgr)++;
    });
    CycloneSide::take<thermovis_msgs_msg_dds__RangeArray_>(ros.ranges, [&](const auto& r) {
      ASSERT_TRUE(fed_.count(r.frame_seq_)) << r.frame_seq_;
      const tv::RangeArray& want = fed_.at(r.frame_seq_).ranges;
      SCOPED_TRACE("ranges of capture " + std::to_string(r.frame_seq_));
      EXPECT_EQ(ns_of(r.header_.stamp_), want.capture_time_ns());
      EXPECT_STREQ(r.header_.frame_id_, "thermovis_visible_left_optical");
      EXPECT_FLOAT_EQ(r.latency_ms_, 4.0f);
      ASSERT_EQ(r.targets_._length, want.targets().size());
      for (std::uint32_t i = 0; i < r.targets_._length; ++i) {
        const auto& got = r.targets_._buffer[i];
        const tv::TargetRange& t = want.targets()[i];
        EXPECT_EQ(got.target_id_, t.target_id());
        EXPECT_EQ(std::string(got.label_), t.label().to_string());
        EXPECT_EQ(got.distance_m_, t.distance_m());
        EXPECT_EQ(got.sigma_m_, t.sigma_m());
        EXPECT_EQ(got.x_m_, t.x_m());
        EXPECT_EQ(got.y_m_, t.y_m());
        EXPECT_EQ(got.z_m_, t.z_m());
        EXPECT_EQ(got.box_.x_, t.box().x());
        EXPECT_EQ(got.box_.y_, t.box().y());
        EXPECT_EQ(got.box_.width_, t.box().width());
        EXPECT_EQ(got.box_.height_, t.box().height());
        EXPECT_EQ(got.point_count_, t.point_count());
        EXPECT_EQ(got.band_, t.band());
      }
      ++ranges;
    });
    CycloneSide::take<thermovis_msgs_msg_dds__ObstacleArray_>(ros.obstacles, [&](const auto& r) {
      ASSERT_TRUE(fed_.count(r.frame_seq_)) << r.frame_seq_;
      const tv::ObstacleArray& want = fed_.at(r.frame_seq_).obstacles;
      SCOPED_TRACE("obstacles of capture " + std::to_string(r.frame_seq_));
      EXPECT_EQ(ns_of(r.header_.stamp_), want.capture_time_ns());
      EXPECT_STREQ(r.header_.frame_id_, "thermovis_visible_left_optical");
      EXPECT_FLOAT_EQ(r.latency_ms_, 6.0f);
      EXPECT_EQ(r.visible_ground_, tv::GROUND_OK);
      EXPECT_EQ(r.infrared_ground_, tv::GROUND_NO_GROUND);
      for (int k = 0; k < 3; ++k) EXPECT_EQ(r.ground_normal_[k], want.ground_normal()[k]);
      EXPECT_EQ(r.ground_height_m_, want.ground_height_m());
      EXPECT_EQ(r.max_distance_m_, want.max_distance_m());
      ASSERT_EQ(r.obstacles_._length, want.obstacles().size());
      for (std::uint32_t i = 0; i < r.obstacles_._length; ++i) {
        const auto& got = r.obstacles_._buffer[i];
        const tv::Obstacle& o = want.obstacles()[i];
        EXPECT_EQ(got.obstacle_id_, o.obstacle_id());
        EXPECT_EQ(std::string(got.label_), o.label().to_string());
        EXPECT_EQ(got.has_target_, o.has_target());
        EXPECT_EQ(got.target_id_, o.target_id());
        EXPECT_EQ(got.distance_m_, o.distance_m());
        EXPECT_EQ(got.sigma_m_, o.sigma_m());
        EXPECT_EQ(got.x_m_, o.x_m());
        EXPECT_EQ(got.y_m_, o.y_m());
        EXPECT_EQ(got.z_m_, o.z_m());
        EXPECT_EQ(got.width_m_, o.width_m());
        EXPECT_EQ(got.height_m_, o.height_m());
        EXPECT_EQ(got.depth_m_, o.depth_m());
        EXPECT_EQ(got.box_.x_, o.box().x());
        EXPECT_EQ(got.box_.height_, o.box().height());
        EXPECT_EQ(got.band_, o.band());
        EXPECT_EQ(got.stixels_, o.stixels());
      }
      ASSERT_EQ(r.free_space_m_._length, want.free_space_m().size());
      ASSERT_EQ(r.free_space_row_._length, want.free_space_row().size());
      for (std::uint32_t i = 0; i < r.free_space_m_._length; ++i) {
        const float m = want.free_space_m()[i], row = want.free_space_row()[i];
        if (std::isnan(m)) {
          EXPECT_TRUE(std::isnan(r.free_space_m_._buffer[i])) << i;
          EXPECT_TRUE(std::isnan(r.free_space_row_._buffer[i])) << i;
        } else {
          EXPECT_EQ(r.free_space_m_._buffer[i], m) << i;
          EXPECT_EQ(r.free_space_row_._buffer[i], row) << i;
        }
      }
      ++obstacles;
    });
  }
  EXPECT_GE(bgr, 4) << bridge.log();
  EXPECT_GE(mono, 4) << bridge.log();
  EXPECT_GE(ranges, 8) << bridge.log();
  EXPECT_GE(obstacles, 8) << bridge.log();

  // The corrupt frame was reported by name and the bridge kept serving.
  const auto reported = wait_health(
      [&](const tv::Health& h) {
        return h.errors() >= 1 && h.frames_processed() >= static_cast<std::uint64_t>(images);
      },
      30s);
  ASSERT_TRUE(reported) << bridge.log();
  EXPECT_EQ(reported->errors(), 1u);
  EXPECT_NE(reported->message().to_string().find("pixel format 77"), std::string::npos)
      << reported->message().to_string();
  EXPECT_GE(reported->frames_processed(), static_cast<std::uint64_t>(images));

  bridge.signal(SIGTERM);
  EXPECT_EQ(bridge.wait(30s), 0) << bridge.log();
  EXPECT_NE(bridge.log().find("pixel format 77"), std::string::npos) << bridge.log();
}

}  // namespace
