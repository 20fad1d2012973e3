// Each service as its own process on a private DDS domain, driven by this test as the DDS
// application on the other side: bad input on the topics it reads is reported (log and health)
// and the next good sample is still served; a configuration naming a missing file is a clear
// error; SIGTERM stops every service with exit code 0.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>

#include "marker_matches.hpp"
#include "pipeline_harness.hpp"
#include "textured_pair.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/obstacles.h"
#include "thermovis/range/ranging.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

using namespace std::chrono_literals;
using thermovis::test::box2d;
using thermovis::test::ChildProcess;
using thermovis::test::marker_matches;
using thermovis::test::pipeline_geometry;
using thermovis::test::receive;
namespace tv = thermovis;
namespace topics = tv::transport::topics;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

class Harness {
 public:
  explicit Harness(int domain) : domain_(domain), dir_(tv::test::temp_dir("services")) {
    participant_ = tv::test::loopback_participant(domain, "services-test");
    // The geometry rectify-fuse would publish: the services started alone wait for it.
    geometry_ = std::make_unique<tv::node::GeometryPublisher>(*participant_, pipeline_geometry());
    health_ = std::make_unique<tv::test::HealthWatch>(*participant_);
  }
  ~Harness() {
    processes_.clear();
    std::filesystem::remove_all(dir_);
  }

  ChildProcess& start(const std::string& executable, std::vector<std::string> extra = {}) {
    processes_.push_back(std::make_unique<ChildProcess>(
        tv::test::service_command(executable, domain_, extra), dir_ / (executable + ".log")));
    return *processes_.back();
  }

  // Waits until the service's health satisfies `ok`; the last health seen.
  std::optional<tv::Health> wait_health(const std::string& service,
                                        const std::function<bool(const tv::Health&)>& ok,
                                        std::chrono::seconds timeout) {
    if (auto health = health_->wait(service, ok, timeout)) return health;
    return health_->last(service);
  }

  tv::transport::Participant& participant() { return *participant_; }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  int domain_;
  std::filesystem::path dir_;
  std::unique_ptr<tv::transport::Participant> participant_;
  std::unique_ptr<tv::node::GeometryPublisher> geometry_;
  std::unique_ptr<tv::test::HealthWatch> health_;
  std::vector<std::unique_ptr<ChildProcess>> processes_;
};

bool running(const tv::Health& h) {
  return h.state() == tv::HEALTH_STARTING || h.state() == tv::HEALTH_OK;
}
bool waiting_for_input(const tv::Health& h) {
  return h.message().to_string().find("waiting") != std::string::npos;
}

// thermovis-range on a private domain, this test writing its matches and reading its ranges.
class RangeService : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(h.wait_health("thermovis-range", waiting_for_input, 60s)) << range.log();
    ASSERT_TRUE(matches.wait_for_readers(1, 10000ms));
    ASSERT_TRUE(ranges.wait_for_writers(1, 10000ms));
  }
  Harness h{tv::test::private_domain()};
  ChildProcess& range = h.start("thermovis-range");
  tv::transport::Writer<tv::MatchArray> matches{h.participant(), topics::kMatches,
                                                tv::transport::event_topic_qos()};
  tv::transport::Reader<tv::RangeArray> ranges{h.participant(), topics::kRanges,
                                               tv::transport::event_topic_qos()};
};

TEST_F(RangeService, ReportsABadMatchArrayAndServesTheNextGoodOne) {
  // A target whose box has a NaN corner.
  tv::MatchArray bad;
  bad.frame_seq(1);
  tv::TargetMatch broken;
  broken.label("person");
  broken.box(box2d(kNaN, 10.f, 20.f, 40.f));
  bad.targets().push_back(broken);
  matches.write(bad);
  const auto reported = h.wait_health(
      "thermovis-range", [](const tv::Health& x) { return x.errors() >= 1; }, 30s);
  ASSERT_TRUE(reported) << range.log();
  EXPECT_EQ(reported->state(), tv::HEALTH_DEGRADED);
  EXPECT_NE(reported->message().to_string().find("non-finite"), std::string::npos)
      << reported->message().to_string();

  // Then a good one: points of a target 12 m ahead, as the matcher would send them.
  tv::MatchArray good;
  good.frame_seq(2);
  const tv::TargetMatch target = marker_matches(7, tv::BAND_VISIBLE);
  good.targets().push_back(target);
  matches.write(good);
  std::optional<tv::RangeArray> answer;
  ASSERT_TRUE(receive<tv::RangeArray>(
      ranges,
      [&](const tv::RangeArray& a) {
        if (a.frame_seq() == 2) answer = a;
        return answer.has_value();
      },
      30s))
      << range.log();
  ASSERT_EQ(answer->targets().size(), 1u);
  const tv::TargetRange& r = answer->targets()[0];
  EXPECT_EQ(r.target_id(), 7u);
  const double truth = std::sqrt(0.3 * 0.3 + 0.2 * 0.2 + 12.0 * 12.0) + 0.033;
  EXPECT_NEAR(r.distance_m(), truth, 0.05);
  // The position is in the left visible camera's frame: its length is the distance.
  EXPECT_NEAR(std::hypot(r.x_m(), r.y_m(), r.z_m()), r.distance_m(), 0.01);
  EXPECT_GT(r.sigma_m(), 0.f);

  range.signal(SIGTERM);
  EXPECT_EQ(range.wait(20s), 0) << range.log();
  EXPECT_NE(range.log().find("non-finite"), std::string::npos) << "the log names the problem";
}

// A target id that comes once per pair (`thermovis-match --band both`): both ranged give one
// range combined from the two (BAND_FUSED) between the two pairs' own; one pair without points
// gives the other's range and band.
TEST_F(RangeService, CombinesATargetsTwoPairsAndNamesTheBand) {
  // The same points sent as the infrared pair's: triangulated with that pair's baseline (longer,
  // and off the grid's axis) they give another distance, so the combination is visible.
  std::map<std::uint64_t, tv::TargetRange> answers;
  auto send = [&](std::uint64_t seq, bool visible_points, bool infrared_points) {
    tv::MatchArray a;
    a.frame_seq(seq);
    tv::TargetMatch v = marker_matches(9, tv::BAND_VISIBLE);
    tv::TargetMatch ir = marker_matches(9, tv::BAND_INFRARED);
    if (!visible_points) v.points().clear();
    if (!infrared_points) ir.points().clear();
    a.targets().push_back(v);
    a.targets().push_back(ir);
    matches.write(a);
    EXPECT_TRUE(receive<tv::RangeArray>(
        ranges,
        [&](const tv::RangeArray& r) {
          if (r.frame_seq() == seq && r.targets().size() == 1) answers[seq] = r.targets()[0];
          return answers.count(seq) > 0;
        },
        30s))
        << "frame " << seq << ": " << range.log();
  };
  send(1, true, false);
  send(2, false, true);
  send(3, true, true);
  ASSERT_EQ(answers.size(), 3u) << range.log();
  const tv::TargetRange &visible = answers[1], &infrared = answers[2], &both = answers[3];
  EXPECT_EQ(visible.band(), tv::BAND_VISIBLE);
  EXPECT_EQ(infrared.band(), tv::BAND_INFRARED);
  EXPECT_EQ(both.band(), tv::BAND_FUSED);
  for (const tv::TargetRange* r : {&visible, &infrared, &both}) EXPECT_EQ(r->target_id(), 9u);
  std::cout << "visible pair " << visible.distance_m() << " +- " << visible.sigma_m()
            << " m, infrared pair " << infrared.distance_m() << " +- " << infrared.sigma_m()
            << " m, combined " << both.distance_m() << " +- " << both.sigma_m() << " m\n";
  EXPECT_GT(std::abs(infrared.distance_m() - visible.distance_m()), 0.05);
  EXPECT_GT(both.distance_m(), std::min(visible.distance_m(), infrared.distance_m()));
  EXPECT_LT(both.distance_m(), std::max(visible.distance_m(), infrared.distance_m()));
  EXPECT_LT(both.sigma_m(), std::min(visible.sigma_m(), infrared.sigma_m()));
  EXPECT_EQ(both.point_count(), visible.point_count() + infrared.point_count());

  range.signal(SIGTERM);
  EXPECT_EQ(range.wait(20s), 0) << range.log();
}

// The textured pair (textured_pair.hpp) in the fused band's format, captured at `seq` s.
void fill_textured_pair(tv::GridStereoFrame& frame, cv::Size grid, int shift, std::uint64_t seq) {
  tv::test::fill_textured_pair(frame, grid, shift, CV_8UC3);
  frame.geometry_id(pipeline_geometry().id());
  frame.seq(seq);
  frame.capture_time_ns(1'000'000'000LL * static_cast<std::int64_t>(seq));
  frame.stamps(tv::PipelineStamps{});
}

TEST(Services, MatchReportsABadDetectionAndServesTheNextGoodOne) {
  Harness h(tv::test::private_domain());
  ChildProcess& match = h.start("thermovis-match", {"--band", "fused"});
  tv::transport::Writer<tv::GridStereoFrame> fused(h.participant(), topics::kFused,
                                                   tv::transport::frame_topic_qos());
  tv::transport::Writer<tv::DetectionArray> detections(h.participant(), topics::kDetections,
                                                       tv::transport::event_topic_qos());
  tv::transport::Reader<tv::MatchArray> matches(h.participant(), topics::kMatches,
                                                tv::transport::event_topic_qos());
  ASSERT_TRUE(h.wait_health("thermovis-match", waiting_for_input, 60s)) << match.log();
  ASSERT_TRUE(fused.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(detections.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(matches.wait_for_writers(1, 10000ms));

  const cv::Size grid = pipeline_geometry().grid_size();
  const int shift = 9;
  {
    // A fused frame with the left eye only (rectify-fuse's default): not a pair to match on.
    auto loan = fused.loan();
    fill_textured_pair(*loan, grid, shift, 4);
    loan->eyes(tv::EYES_LEFT);
    fused.publish(std::move(loan));
  }
  const auto left_only = h.wait_health(
      "thermovis-match", [](const tv::Health& x) { return x.errors() >= 1; }, 30s);
  ASSERT_TRUE(left_only) << match.log();
  EXPECT_NE(left_only->message().to_string().find("--fused-eyes both"), std::string::npos)
      << left_only->message().to_string();
  for (std::uint64_t seq : {5u, 6u}) {
    auto loan = fused.loan();
    fill_textured_pair(*loan, grid, shift, seq);
    fused.publish(std::move(loan));
    std::this_thread::sleep_for(50ms);
  }
  auto detection_array = [](std::uint64_t seq, tv::Box2D box) {
    tv::DetectionArray a;
    a.frame_seq(seq);
    tv::Detection d;
    d.target_id(3);
    d.label("person");
    d.score(0.9f);
    d.box(box);
    a.detections().push_back(d);
    return a;
  };
  detections.write(detection_array(5, box2d(100.f, 100.f, kNaN, 50.f)));
  const auto reported = h.wait_health(
      "thermovis-match", [](const tv::Health& x) { return x.errors() >= 2; }, 30s);
  ASSERT_TRUE(reported) << match.log();
  EXPECT_NE(reported->message().to_string().find("non-finite"), std::string::npos)
      << reported->message().to_string();

  detections.write(detection_array(6, box2d(400.f, 200.f, 40.f, 60.f)));
  std::optional<tv::MatchArray> answer;
  ASSERT_TRUE(receive<tv::MatchArray>(
      matches,
      [&](const tv::MatchArray& a) {
        if (a.frame_seq() == 6) answer = a;
        return answer.has_value();
      },
      30s))
      << match.log();
  ASSERT_EQ(answer->targets().size(), 1u);
  const auto& points = answer->targets()[0].points();
  ASSERT_GE(points.size(), 10u);
  for (const tv::PointMatch& p : points) {
    EXPECT_NEAR(p.left_x() - p.right_x(), shift, 0.2);
    EXPECT_NEAR(p.left_y(), p.right_y(), 0.5);
  }
  match.signal(SIGTERM);
  EXPECT_EQ(match.wait(20s), 0) << match.log();
}

// A rectified pair of infrared counts (MONO16): the textured pair's grey x 16 + 6000.
void fill_infrared_pair(tv::GridStereoFrame& frame, cv::Size grid, int shift) {
  const auto grey = std::make_unique<tv::GridStereoFrame>();  // 26 MB: not on the stack
  tv::test::fill_textured_pair(*grey, grid, shift, CV_8UC1);
  for (const auto eye : {tv::node::Eye::left, tv::node::Eye::right}) {
    tv::node::view(*grey, eye)
        .convertTo(tv::node::prepare(frame, eye, grid, CV_16UC1), CV_16U, 16, 6000);
  }
  frame.eyes(tv::EYES_BOTH);
}

TEST(Services, ObstaclesReportsABadFrameAndGivesAWallAStatusNotObstacles) {
  Harness h(tv::test::private_domain());
  ChildProcess& obstacles = h.start("thermovis-obstacles", {"--no-targets"});
  tv::transport::Writer<tv::GridStereoFrame> visible(h.participant(), topics::kRectifiedVisible,
                                                     tv::transport::frame_topic_qos());
  tv::transport::Writer<tv::GridStereoFrame> infrared(h.participant(), topics::kRectifiedInfrared,
                                                      tv::transport::frame_topic_qos());
  tv::transport::Reader<tv::ObstacleArray> out(h.participant(), topics::kObstacles,
                                               tv::transport::event_topic_qos());
  ASSERT_TRUE(h.wait_health("thermovis-obstacles", waiting_for_input, 60s)) << obstacles.log();
  ASSERT_TRUE(visible.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(infrared.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(out.wait_for_writers(1, 10000ms));

  const cv::Size grid = pipeline_geometry().grid_size();
  {
    // 8-bit pixels on the infrared topic: not the counts the pair is searched in.
    auto loan = infrared.loan();
    tv::test::fill_textured_pair(*loan, grid, 6, CV_8UC3);
    loan->seq(1);
    infrared.publish(std::move(loan));
  }
  const auto reported = h.wait_health(
      "thermovis-obstacles", [](const tv::Health& x) { return x.errors() >= 1; }, 30s);
  ASSERT_TRUE(reported) << obstacles.log();
  EXPECT_NE(reported->message().to_string().find("MONO16"), std::string::npos)
      << reported->message().to_string();

  // A textured wall across the whole view at one disparity, in both pairs: no ground near the
  // prior, so a status and no obstacle.
  {
    auto ir = infrared.loan();
    fill_infrared_pair(*ir, grid, 6);
    ir->seq(2);
    infrared.publish(std::move(ir));
    auto vis = visible.loan();
    tv::test::fill_textured_pair(*vis, grid, 6, CV_8UC3);
    vis->seq(2);
    visible.publish(std::move(vis));
  }
  std::optional<tv::ObstacleArray> answer;
  ASSERT_TRUE(receive<tv::ObstacleArray>(
      out,
      [&](const tv::ObstacleArray& a) {
        if (a.frame_seq() == 2) answer = a;
        return answer.has_value();
      },
      30s))
      << obstacles.log();
  EXPECT_NE(answer->visible_ground(), tv::GROUND_OK);
  EXPECT_NE(answer->visible_ground(), tv::GROUND_NOT_SEARCHED);
  EXPECT_NE(answer->infrared_ground(), tv::GROUND_OK);
  EXPECT_NE(answer->infrared_ground(), tv::GROUND_NOT_SEARCHED);
  EXPECT_TRUE(answer->obstacles().empty());
  ASSERT_EQ(answer->free_space_m().size(), static_cast<std::size_t>(grid.width));
  for (float f : answer->free_space_m()) EXPECT_TRUE(std::isnan(f));
  obstacles.signal(SIGTERM);
  EXPECT_EQ(obstacles.wait(20s), 0) << obstacles.log();
}

// The bridge's two raw frame topics, publishing one capture: uniform infrared and visible
// pairs, the visible one's header saying `visible_size` (its pixels fit the frame type).
struct RawCaptures {
  explicit RawCaptures(tv::transport::Participant& participant)
      : visible(participant, topics::kVisibleFrames, tv::transport::frame_topic_qos()),
        infrared(participant, topics::kInfraredFrames, tv::transport::frame_topic_qos()) {}
  bool wait_for_rectify_fuse() {
    return visible.wait_for_readers(1, 10000ms) && infrared.wait_for_readers(1, 10000ms);
  }
  void publish(std::uint64_t seq, cv::Size visible_size = {1920, 1080},
               std::int64_t capture_time_ns = 0) {
    auto ir = infrared.loan();
    cv::Mat il = tv::node::prepare(*ir, tv::node::Eye::left, {1024, 768});
    cv::Mat ir_right = tv::node::prepare(*ir, tv::node::Eye::right, {1024, 768});
    il.setTo(8000);
    ir_right.setTo(8000);
    ir->seq(seq);
    ir->capture_time_ns(capture_time_ns);
    ir->stamps(tv::PipelineStamps{});
    auto vis = visible.loan();
    // The header says what the test wants; the pixels of a wrong size are never read.
    const cv::Size fits(std::min(visible_size.width, 1920), std::min(visible_size.height, 1080));
    tv::node::prepare(*vis, tv::node::Eye::left, fits).setTo(cv::Scalar(90, 100, 110));
    tv::node::prepare(*vis, tv::node::Eye::right, fits).setTo(cv::Scalar(90, 100, 110));
    vis->width(static_cast<std::uint32_t>(visible_size.width));
    vis->height(static_cast<std::uint32_t>(visible_size.height));
    vis->seq(seq);
    vis->capture_time_ns(capture_time_ns);
    vis->stamps(tv::PipelineStamps{});
    infrared.publish(std::move(ir));
    visible.publish(std::move(vis));
  }
  tv::transport::Writer<tv::VisibleStereoFrame> visible;
  tv::transport::Writer<tv::InfraredStereoFrame> infrared;
};

TEST(Services, RectifyFuseReportsAWrongSizedFrameAndServesTheNextGoodOne) {
  Harness h(tv::test::private_domain());
  ChildProcess& rf = h.start("thermovis-rectify-fuse");
  RawCaptures raw(h.participant());
  tv::transport::Reader<tv::GridStereoFrame> fused(h.participant(), topics::kFused,
                                                   tv::transport::frame_topic_qos());
  ASSERT_TRUE(h.wait_health("thermovis-rectify-fuse", waiting_for_input, 120s)) << rf.log();
  ASSERT_TRUE(raw.wait_for_rectify_fuse());
  ASSERT_TRUE(fused.wait_for_writers(1, 10000ms));
  raw.publish(1, {4000, 1080});  // does not fit the frame type
  const auto reported = h.wait_health(
      "thermovis-rectify-fuse", [](const tv::Health& x) { return x.errors() >= 1; }, 30s);
  ASSERT_TRUE(reported) << rf.log();
  EXPECT_NE(reported->message().to_string().find("4000x1080"), std::string::npos)
      << reported->message().to_string();
  raw.publish(2);
  cv::Size fused_size;
  tv::EyeSet fused_eyes = tv::EYES_BOTH;
  cv::Scalar fused_mean;
  ASSERT_TRUE(receive<tv::GridStereoFrame>(
      fused,
      [&](const tv::GridStereoFrame& f) {
        fused_size = cv::Size(static_cast<int>(f.width()), static_cast<int>(f.height()));
        fused_eyes = f.eyes();
        if (f.seq() == 2) fused_mean = cv::mean(tv::node::view(f, tv::node::Eye::left));
        return f.seq() == 2;
      },
      30s))
      << rf.log();
  EXPECT_EQ(fused_size, pipeline_geometry().grid_size());
  // The display's frame: the left eye fused (a uniform grey scene inside the field), no right.
  EXPECT_EQ(fused_eyes, tv::EYES_LEFT);
  EXPECT_GT(fused_mean[0] + fused_mean[1] + fused_mean[2], 30.0);
  rf.signal(SIGTERM);
  EXPECT_EQ(rf.wait(20s), 0) << rf.log();
}

// Nothing reads thermovis/fused in the default pipeline: rectify-fuse rectifies every capture
// but fuses only while the fused topic has a reader, and fuses again as soon as one comes.
TEST(Services, RectifyFuseFusesOnlyWhileTheFusedTopicHasAReader) {
  Harness h(tv::test::private_domain());
  ChildProcess& rf = h.start("thermovis-rectify-fuse");
  RawCaptures raw(h.participant());
  tv::transport::Reader<tv::GridStereoFrame> rectified(h.participant(), topics::kRectifiedVisible,
                                                       tv::transport::frame_topic_qos());
  ASSERT_TRUE(h.wait_health("thermovis-rectify-fuse", waiting_for_input, 120s)) << rf.log();
  ASSERT_TRUE(raw.wait_for_rectify_fuse());
  ASSERT_TRUE(rectified.wait_for_writers(1, 10000ms));
  const auto samples_on = [](const tv::Health& health, const std::string& topic) {
    for (const auto& t : health.topics())
      if (t.topic().to_string() == topic) return static_cast<long long>(t.samples());
    return -1LL;
  };
  for (std::uint64_t seq = 1; seq <= 3; ++seq) {
    raw.publish(seq);
    ASSERT_TRUE(receive<tv::GridStereoFrame>(
        rectified,
        [&](const tv::GridStereoFrame& f) {
          // The luma by default (--visible-encoding mono8).
          EXPECT_EQ(f.pixel_format(), tv::PIXEL_FORMAT_MONO8);
          return f.seq() == seq;
        },
        30s))
        << rf.log();
  }
  const auto unread = h.wait_health(
      "thermovis-rectify-fuse",
      [&](const tv::Health& x) { return samples_on(x, topics::kRectifiedVisible) >= 3; }, 30s);
  ASSERT_TRUE(unread) << rf.log();
  EXPECT_EQ(samples_on(*unread, topics::kFused), 0) << rf.log();

  tv::transport::Reader<tv::GridStereoFrame> fused(h.participant(), topics::kFused,
                                                   tv::transport::frame_topic_qos());
  ASSERT_TRUE(fused.wait_for_writers(1, 10000ms));
  // The writer learns of the reader a moment after the reader of the writer: a few captures.
  bool received = false;
  for (std::uint64_t seq = 4; seq <= 40 && !received; ++seq) {
    raw.publish(seq);
    received = receive<tv::GridStereoFrame>(
        fused, [&](const tv::GridStereoFrame& f) { return f.seq() == seq; }, 1s);
  }
  EXPECT_TRUE(received) << rf.log();
  rf.signal(SIGTERM);
  EXPECT_EQ(rf.wait(20s), 0) << rf.log();
}

// The display's fused image at --fused-rate-hz: captures 20 ms apart at 25 Hz are fused every
// other one, every one rectified; with both eyes fused (fused-band matching) every capture. The
// fused image is in colour whether the rectified visible pair is (--visible-encoding bgr8, the
// second run) or not.
TEST(Services, RectifyFuseFusesAtTheFusedRateExceptForFusedBandMatching) {
  for (const bool both_eyes : {false, true}) {
    Harness h(tv::test::private_domain());
    std::vector<std::string> args = {"--fused-rate-hz", "25"};
    if (both_eyes) args.insert(args.end(), {"--fused-eyes", "both", "--visible-encoding", "bgr8"});
    ChildProcess& rf = h.start("thermovis-rectify-fuse", args);
    RawCaptures raw(h.participant());
    tv::transport::Reader<tv::GridStereoFrame> rectified(h.participant(), topics::kRectifiedVisible,
                                                         tv::transport::frame_topic_qos());
    // A reader of the display's kind: no DEADLINE of its own (the decimated writer offers the
    // pipeline's plus 1 / rate, which a reader asking for 20 ms would not match).
    tv::transport::Reader<tv::GridStereoFrame> fused(
        h.participant(), topics::kFused,
        tv::transport::observer_qos(tv::transport::frame_topic_qos()));
    ASSERT_TRUE(h.wait_health("thermovis-rectify-fuse", waiting_for_input, 120s)) << rf.log();
    ASSERT_TRUE(raw.wait_for_rectify_fuse());
    ASSERT_TRUE(rectified.wait_for_writers(1, 10000ms) && fused.wait_for_writers(1, 10000ms));
    std::vector<std::uint64_t> fused_seqs;
    const auto take_fused = [&] {
      auto samples = fused.take();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        EXPECT_EQ(samples[i].pixel_format(), tv::PIXEL_FORMAT_BGR8);
        fused_seqs.push_back(samples[i].seq());
      }
    };
    constexpr std::int64_t kPeriodNs = 20'000'000;
    for (std::uint64_t seq = 1; seq <= 40; ++seq) {
      raw.publish(seq, {1920, 1080}, static_cast<std::int64_t>(seq) * kPeriodNs);
      ASSERT_TRUE(receive<tv::GridStereoFrame>(
          rectified,
          [&](const tv::GridStereoFrame& f) {
            EXPECT_EQ(f.pixel_format(), both_eyes ? tv::PIXEL_FORMAT_BGR8 : tv::PIXEL_FORMAT_MONO8);
            return f.seq() == seq;
          },
          30s))
          << rf.log();
      fused.wait_for_data(200ms);
      take_fused();
    }
    // The writer learns of the reader a few captures late; from its first fused capture on:
    ASSERT_GE(fused_seqs.size(), 8u) << rf.log();
    for (std::size_t i = 1; i < fused_seqs.size(); ++i)
      EXPECT_EQ(fused_seqs[i] - fused_seqs[i - 1], both_eyes ? 1u : 2u)
          << "after " << fused_seqs[i - 1];
    rf.signal(SIGTERM);
    EXPECT_EQ(rf.wait(20s), 0) << rf.log();
  }
}

TEST(Services, AConfigurationNamingAMissingFileIsAClearError) {
  Harness h(tv::test::private_domain());
  // The services that read the rig; the others take the geometry from thermovis/geometry and
  // refuse a --rig they would not read.
  for (const char* service : {"thermovis-bridge", "thermovis-rectify-fuse"}) {
    ChildProcess& p = h.start(service, {"--rig", "/nonexistent/thermovis/rig.yaml"});
    EXPECT_EQ(p.wait(30s), 1) << service;
    EXPECT_NE(p.log().find("/nonexistent/thermovis/rig.yaml"), std::string::npos)
        << service << ":\n"
        << p.log();
  }
  for (const char* service : {"thermovis-detect", "thermovis-match", "thermovis-range"}) {
    ChildProcess& p = h.start(service, {"--rig", "/nonexistent/thermovis/rig.yaml"});
    EXPECT_NE(p.wait(30s), 0) << service;
    EXPECT_NE(p.log().find("--rig"), std::string::npos) << service << ":\n" << p.log();
  }
}

TEST(Services, EveryServiceStopsCleanlyOnSigterm) {
  Harness h(tv::test::private_domain());
  std::map<std::string, ChildProcess*> services;
  services["thermovis-bridge"] = &h.start("thermovis-bridge", {"--source", "sim"});
  for (const char* name : {"thermovis-rectify-fuse", "thermovis-detect", "thermovis-match",
                           "thermovis-range", "thermovis-obstacles"}) {
    services[name] = &h.start(name);
  }
  for (const auto& [name, process] : services) {
    ASSERT_TRUE(h.wait_health(name, running, 120s)) << name << ":\n" << process->log();
  }
  // Let frames flow for a moment, so the services stop in the middle of their work; then stop
  // them downstream first, as the supervisor does (deploy/pipeline.yaml says why).
  std::this_thread::sleep_for(2s);
  for (const char* name : {"thermovis-obstacles", "thermovis-range", "thermovis-match",
                           "thermovis-detect", "thermovis-rectify-fuse", "thermovis-bridge"}) {
    ChildProcess* process = services.at(name);
    process->signal(SIGTERM);
    EXPECT_EQ(process->wait(30s), 0) << name << ":\n" << process->log();
  }
}

// systemd's side of sd_notify: a datagram socket the service's notifications arrive on.
class NotifySocket {
 public:
  explicit NotifySocket(const std::filesystem::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof(address.sun_path) - 1);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof(address)) != 0)
      throw std::runtime_error("cannot bind " + path.string());
  }
  ~NotifySocket() {
    ::close(fd_);
    std::filesystem::remove(path_);
  }
  // The next message, or "" after `timeout`.
  std::string receive(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return "";
    char buffer[512];
    const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
    return n > 0 ? std::string(buffer, static_cast<std::size_t>(n)) : "";
  }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

TEST(Services, TellSystemdWhenReadyAndPingItsWatchdog) {
  Harness h(tv::test::private_domain());
  NotifySocket notify(h.dir() / "notify.sock");
  // As systemd starts a Type=notify unit with WatchdogSec=0.4.
  ChildProcess range(
      tv::test::service_command("thermovis-range", tv::test::private_domain()),
      h.dir() / "range.log",
      {{"NOTIFY_SOCKET", (h.dir() / "notify.sock").string()}, {"WATCHDOG_USEC", "400000"}});
  const std::string ready = notify.receive(60s);
  EXPECT_EQ(ready.rfind("READY=1", 0), 0u) << ready << "\n" << range.log();
  // Idle (no matches arrive) the loop still turns: at least one ping per 0.2 s.
  int pings = 0;
  const auto until = std::chrono::steady_clock::now() + 2s;
  while (std::chrono::steady_clock::now() < until) {
    if (notify.receive(500ms) == "WATCHDOG=1") ++pings;
  }
  EXPECT_GE(pings, 6) << range.log();
  range.signal(SIGTERM);
  std::string message;
  do {
    message = notify.receive(10s);  // a last watchdog ping may come first
  } while (message == "WATCHDOG=1");
  EXPECT_EQ(message, "STOPPING=1");
  EXPECT_EQ(range.wait(20s), 0) << range.log();
}

}  // namespace
