// Corrupt inputs on every topic a service reads, each service as its own process on a private DDS
// domain with this test as the DDS application on the other side. Each kind of corruption (wrong
// sizes, truncated images, impossible values: zero or negative sizes, unknown pixel formats, a
// wrong row step, NaN/inf in boxes and points, unknown bands, repeated ids, stage stamps out of
// order, a capture arriving after a newer one) is sent alone; the service must count it as an
// error in its health, whose message names it, and then serve the next good sample.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <thread>
#include <tuple>

#include "marker_matches.hpp"
#include "pipeline_harness.hpp"
#include "supervisor.hpp"
#include "textured_pair.hpp"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/range/ranging.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/clock.hpp"
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
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::int64_t kSecond = 1'000'000'000;

// One service process and the health it publishes.
class Service {
 public:
  Service(const std::string& executable, std::vector<std::string> extra = {})
      : domain_(tv::test::private_domain()),
        dir_(tv::test::temp_dir("corrupt")),
        name_(executable) {
    participant_ = tv::test::loopback_participant(domain_, "corrupt-test");
    // The geometry rectify-fuse would publish: the services started alone wait for it.
    geometry_ = std::make_unique<tv::node::GeometryPublisher>(*participant_, pipeline_geometry());
    health_ = std::make_unique<tv::test::HealthWatch>(*participant_);
    process_ = std::make_unique<ChildProcess>(tv::test::service_command(executable, domain_, extra),
                                              dir_ / (executable + ".log"));
  }
  ~Service() {
    process_.reset();
    std::filesystem::remove_all(dir_);
  }

  // The last health satisfying `ok` within `timeout`.
  std::optional<tv::Health> wait_health(const std::function<bool(const tv::Health&)>& ok,
                                        std::chrono::seconds timeout) {
    return health_->wait(name_, ok, timeout);
  }

  bool ready(std::chrono::seconds timeout) {
    return wait_health(
               [](const tv::Health& h) {
                 return h.message().to_string().find("waiting") != std::string::npos;
               },
               timeout)
        .has_value();
  }

  // Sends one corrupt sample (send()) and checks that the service counts one more error whose
  // message holds `says`.
  void expect_named(const std::string& kind, const std::function<void()>& send,
                    const std::string& says) {
    SCOPED_TRACE(kind);
    const auto last = health_->last(name_);
    const std::uint32_t before = last ? last->errors() : 0;
    send();
    const auto health = wait_health([&](const tv::Health& h) { return h.errors() > before; }, 30s);
    ASSERT_TRUE(health) << kind << " was not reported\n" << process_->log();
    EXPECT_EQ(health->errors(), before + 1) << health->message().to_string();
    EXPECT_NE(health->message().to_string().find(says), std::string::npos)
        << kind << ": '" << says << "' not in: " << health->message().to_string();
    EXPECT_EQ(health->state(), tv::HEALTH_DEGRADED);
  }

  // Stops the service: it exits cleanly and its log names the problems too.
  void stop_and_check_log(const std::vector<std::string>& says) {
    process_->signal(SIGTERM);
    EXPECT_EQ(process_->wait(30s), 0) << process_->log();
    for (const auto& fragment : says)
      EXPECT_NE(process_->log().find(fragment), std::string::npos) << fragment << " not in log";
  }

  tv::transport::Participant& participant() { return *participant_; }
  std::string log() const { return process_->log(); }

 private:
  int domain_;
  std::filesystem::path dir_;
  std::string name_;
  std::unique_ptr<tv::transport::Participant> participant_;
  std::unique_ptr<tv::node::GeometryPublisher> geometry_;
  std::unique_ptr<tv::test::HealthWatch> health_;
  std::unique_ptr<ChildProcess> process_;
};

// Stamps of the stages a sample went through, ending at the given times (ns).
tv::PipelineStamps stamps(std::initializer_list<std::pair<tv::Stage, std::int64_t>> stages) {
  tv::PipelineStamps out;
  std::size_t i = 0;
  for (const auto& [stage, end_ns] : stages) {
    out.stamps()[i].stage(stage);
    out.stamps()[i].duration_us(1000);
    out.stamps()[i].end_ns(end_ns);
    ++i;
  }
  return out;
}

TEST(Corrupt, RangeNamesEveryBadMatchArrayAndServesTheNextGoodOne) {
  Service range("thermovis-range");
  tv::transport::Writer<tv::MatchArray> matches(range.participant(), topics::kMatches,
                                                tv::transport::event_topic_qos());
  tv::transport::Reader<tv::RangeArray> ranges(range.participant(), topics::kRanges,
                                               tv::transport::event_topic_qos());
  ASSERT_TRUE(range.ready(60s)) << range.log();
  ASSERT_TRUE(matches.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(ranges.wait_for_writers(1, 10000ms));

  std::uint64_t seq = 100;
  const std::int64_t t0 = 1'700'000'000 * kSecond;
  // A good array of one target, then broken by `corrupt`.
  auto send = [&](const std::function<void(tv::MatchArray&)>& corrupt) {
    return [&, corrupt] {
      tv::MatchArray a;
      a.frame_seq(++seq);
      a.capture_time_ns(t0 + static_cast<std::int64_t>(seq) * 20'000'000);
      a.targets().push_back(marker_matches(7, tv::BAND_VISIBLE));
      corrupt(a);
      matches.write(a);
    };
  };
  range.expect_named("NaN in a box", send([](tv::MatchArray& a) { a.targets()[0].box().x(kNaN); }),
                     "non-finite field");
  range.expect_named("inf in a point",
                     send([](tv::MatchArray& a) { a.targets()[0].points()[3].right_x(kInf); }),
                     "point 3 has a non-finite coordinate");
  range.expect_named("negative box size",
                     send([](tv::MatchArray& a) { a.targets()[0].box().width(-20.f); }),
                     "box with no area");
  range.expect_named("unknown band", send([](tv::MatchArray& a) { a.targets()[0].band(9); }),
                     "unknown band 9");
  range.expect_named("a target id twice", send([](tv::MatchArray& a) {
                       a.targets().push_back(marker_matches(7, tv::BAND_VISIBLE));
                     }),
                     "target 7 of frame 105: target id given twice");
  range.expect_named("stages out of order", send([&](tv::MatchArray& a) {
                       const std::int64_t c = a.capture_time_ns();
                       a.stamps(stamps({{tv::STAGE_BRIDGE, c + 1'000'000},
                                        {tv::STAGE_DETECT, c + 5'000'000},
                                        {tv::STAGE_RECTIFY_FUSE, c + 9'000'000}}));
                     }),
                     "stage 2 after stage 3 (stamps out of order)");
  range.expect_named("an unknown stage", send([&](tv::MatchArray& a) {
                       a.stamps(stamps({{42, a.capture_time_ns() + 1'000'000}}));
                     }),
                     "unknown stage 42");
  range.expect_named("a stage ending before the capture", send([&](tv::MatchArray& a) {
                       a.stamps(stamps({{tv::STAGE_BRIDGE, a.capture_time_ns() - 10 * kSecond}}));
                     }),
                     "ends 10000 ms before the capture");

  // The next good array is ranged.
  send([&](tv::MatchArray& a) {
    const std::int64_t c = a.capture_time_ns();
    a.stamps(stamps({{tv::STAGE_BRIDGE, c + 1'000'000}, {tv::STAGE_MATCH, c + 9'000'000}}));
  })();
  std::optional<tv::RangeArray> answer;
  ASSERT_TRUE(receive<tv::RangeArray>(
      ranges,
      [&](const tv::RangeArray& a) {
        if (a.frame_seq() == seq) answer = a;
        return answer.has_value();
      },
      30s))
      << range.log();
  ASSERT_EQ(answer->targets().size(), 1u);
  EXPECT_NEAR(answer->targets()[0].distance_m(), std::sqrt(0.3 * 0.3 + 0.2 * 0.2 + 144.0) + 0.033,
              0.05);
  range.stop_and_check_log({"point 3 has a non-finite coordinate", "unknown band 9"});
}

// A rectified infrared pair (raw counts) on the pipeline grid: a 25 C background with a warm
// person-sized block (noise of 30 counts), as detection sees them.
void fill_infrared(tv::GridStereoFrame& frame, cv::Size grid, std::uint64_t seq,
                   std::int64_t capture_ns) {
  for (const auto eye : {tv::node::Eye::left, tv::node::Eye::right}) {
    cv::Mat image = tv::node::prepare(frame, eye, grid, CV_16UC1);
    cv::randn(image, 8000, 30);
    image(cv::Rect(grid.width / 2, grid.height / 2, 20, 50)).setTo(9500);
  }
  frame.eyes(tv::EYES_BOTH);
  frame.geometry_id(pipeline_geometry().id());
  frame.seq(seq);
  frame.capture_time_ns(capture_ns);
  frame.stamps(stamps({{tv::STAGE_BRIDGE, capture_ns + 1'000'000},
                       {tv::STAGE_RECTIFY_FUSE, capture_ns + 6'000'000}}));
}

TEST(Corrupt, DetectNamesEveryBadFrameAndServesTheNextGoodOne) {
  Service detect("thermovis-detect");
  tv::transport::Writer<tv::GridStereoFrame> infrared(
      detect.participant(), topics::kRectifiedInfrared, tv::transport::frame_topic_qos());
  tv::transport::Reader<tv::DetectionArray> detections(detect.participant(), topics::kDetections,
                                                       tv::transport::event_topic_qos());
  ASSERT_TRUE(detect.ready(60s)) << detect.log();
  ASSERT_TRUE(infrared.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(detections.wait_for_writers(1, 10000ms));

  const cv::Size grid = pipeline_geometry().grid_size();
  const std::int64_t t0 = 1'700'000'000 * kSecond;
  std::uint64_t seq = 10;
  auto send = [&](const std::function<void(tv::GridStereoFrame&)>& corrupt) {
    return [&, corrupt] {
      auto loan = infrared.loan();
      ++seq;
      fill_infrared(*loan, grid, seq, t0 + static_cast<std::int64_t>(seq) * 20'000'000);
      corrupt(*loan);
      infrared.publish(std::move(loan));
    };
  };
  const std::string w = std::to_string(grid.width), h = std::to_string(grid.height);
  detect.expect_named("another grid", send([&](tv::GridStereoFrame& f) {
                        f.width(f.width() - 2);
                        f.step(f.width() * 2);
                      }),
                      std::to_string(grid.width - 2) + "x" + h + " image, this service's grid is");
  detect.expect_named("another geometry",
                      send([](tv::GridStereoFrame& f) { f.geometry_id(12345); }),
                      "was made on geometry 12345");
  detect.expect_named("an unknown pixel format",
                      send([](tv::GridStereoFrame& f) { f.pixel_format(9); }),
                      "unknown pixel format 9");
  detect.expect_named("colour instead of counts", send([&](tv::GridStereoFrame& f) {
                        f.pixel_format(tv::PIXEL_FORMAT_BGR8);
                        f.step(f.width() * 3);
                      }),
                      "expected MONO8 or MONO16");
  detect.expect_named("an unknown eye set", send([](tv::GridStereoFrame& f) { f.eyes(5); }),
                      "unknown eye set 5");
  detect.expect_named("a zero height", send([](tv::GridStereoFrame& f) { f.height(0); }),
                      "empty image");
  detect.expect_named("a negative width",
                      send([](tv::GridStereoFrame& f) { f.width(static_cast<std::uint32_t>(-1)); }),
                      "does not fit");
  detect.expect_named("a padded row step",
                      send([](tv::GridStereoFrame& f) { f.step(f.step() + 64); }),
                      "step " + std::to_string(grid.width * 2 + 64) + " bytes");
  detect.expect_named("stages out of order", send([](tv::GridStereoFrame& f) {
                        f.stamps(stamps({{tv::STAGE_RECTIFY_FUSE, f.capture_time_ns() + 1000},
                                         {tv::STAGE_BRIDGE, f.capture_time_ns() + 2000}}));
                      }),
                      "stamps out of order");
  // A capture older than the last one, arriving late (a newer one was taken before).
  const std::uint64_t last = seq;
  detect.expect_named("an older capture", send([&](tv::GridStereoFrame& f) {
                        f.seq(last - 5);
                        f.capture_time_ns(t0 + static_cast<std::int64_t>(last - 5) * 20'000'000);
                      }),
                      "captured before frame " + std::to_string(last) + ": out of order");

  send([](tv::GridStereoFrame&) {})();
  std::optional<tv::DetectionArray> answer;
  ASSERT_TRUE(receive<tv::DetectionArray>(
      detections,
      [&](const tv::DetectionArray& a) {
        if (a.frame_seq() == seq) answer = a;
        return answer.has_value();
      },
      30s))
      << detect.log();
  // The warm block is found where it is.
  ASSERT_GE(answer->detections().size(), 1u) << detect.log();
  const cv::Rect found = tv::node::to_rect(answer->detections()[0].box());
  EXPECT_TRUE(found.contains({grid.width / 2 + 10, grid.height / 2 + 25})) << found;
  detect.stop_and_check_log({"unknown pixel format 9", "stamps out of order"});
}

TEST(Corrupt, RectifyFuseNamesEveryBadRawFrameAndServesTheNextGoodOne) {
  Service rf("thermovis-rectify-fuse");
  tv::transport::Writer<tv::VisibleStereoFrame> visible(rf.participant(), topics::kVisibleFrames,
                                                        tv::transport::frame_topic_qos());
  tv::transport::Writer<tv::InfraredStereoFrame> infrared(rf.participant(), topics::kInfraredFrames,
                                                          tv::transport::frame_topic_qos());
  tv::transport::Reader<tv::GridStereoFrame> fused(rf.participant(), topics::kFused,
                                                   tv::transport::frame_topic_qos());
  ASSERT_TRUE(rf.ready(120s)) << rf.log();
  ASSERT_TRUE(visible.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(infrared.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(fused.wait_for_writers(1, 10000ms));

  const std::int64_t t0 = 1'700'000'000 * kSecond;
  std::uint64_t seq = 0;
  using Corrupt = std::function<void(tv::VisibleStereoFrame&, tv::InfraredStereoFrame&)>;
  auto send = [&](const Corrupt& corrupt) {
    return [&, corrupt] {
      ++seq;
      const std::int64_t capture = t0 + static_cast<std::int64_t>(seq) * 20'000'000;
      const auto frame_stamps = stamps({{tv::STAGE_BRIDGE, capture + 1'000'000}});
      auto ir = infrared.loan();
      for (const auto eye : {tv::node::Eye::left, tv::node::Eye::right})
        tv::node::prepare(*ir, eye, {1024, 768}).setTo(8000);
      ir->seq(seq);
      ir->capture_time_ns(capture);
      ir->stamps(frame_stamps);
      auto vis = visible.loan();
      for (const auto eye : {tv::node::Eye::left, tv::node::Eye::right})
        tv::node::prepare(*vis, eye, {1920, 1080}).setTo(cv::Scalar(90, 100, 110));
      vis->seq(seq);
      vis->capture_time_ns(capture);
      vis->stamps(frame_stamps);
      corrupt(*vis, *ir);
      infrared.publish(std::move(ir));
      visible.publish(std::move(vis));
    };
  };
  rf.expect_named("an unknown pixel format", send([](auto& vis, auto&) { vis.pixel_format(7); }),
                  "pixel format 7, expected 1");
  rf.expect_named("infrared in 8 bits",
                  send([](auto&, auto& ir) { ir.pixel_format(tv::PIXEL_FORMAT_MONO8); }),
                  "pixel format 2, expected 3");
  rf.expect_named("a zero width", send([](auto& vis, auto&) { vis.width(0); }), "empty image");
  rf.expect_named("a negative height",
                  send([](auto& vis, auto&) { vis.height(static_cast<std::uint32_t>(-1080)); }),
                  "does not fit");
  rf.expect_named("a truncated image", send([](auto& vis, auto&) { vis.height(540); }),
                  "input image is 1920x540 but the table was made for a 1920x1080 camera");
  rf.expect_named("a wrong row step", send([](auto&, auto& ir) { ir.step(1024); }),
                  "step 1024 bytes, the packed rows of a 1024x768 image are 2048");
  rf.expect_named("stamps before the capture", send([](auto& vis, auto&) {
                    vis.stamps(stamps({{tv::STAGE_BRIDGE, vis.capture_time_ns() - 5 * kSecond}}));
                  }),
                  "ends 5000 ms before the capture");

  send([](auto&, auto&) {})();
  ASSERT_TRUE(receive<tv::GridStereoFrame>(
      fused, [&](const tv::GridStereoFrame& f) { return f.seq() == seq; }, 30s))
      << rf.log();
  rf.stop_and_check_log({"pixel format 7, expected 1", "1920x540"});
}

// The textured pair (textured_pair.hpp) as rectify-fuse would have stamped it.
void fill_textured_pair(tv::GridStereoFrame& frame, cv::Size grid, int shift, std::uint64_t seq,
                        std::int64_t capture_ns) {
  tv::test::fill_textured_pair(frame, grid, shift, CV_8UC1);
  frame.geometry_id(pipeline_geometry().id());
  frame.seq(seq);
  frame.capture_time_ns(capture_ns);
  frame.stamps(stamps({{tv::STAGE_BRIDGE, capture_ns + 1'000'000},
                       {tv::STAGE_RECTIFY_FUSE, capture_ns + 9'000'000}}));
}

TEST(Corrupt, MatchNamesBadFramesAndDetectionsAndServesTheNextGoodOnes) {
  Service match("thermovis-match", {"--band", "fused"});
  tv::transport::Writer<tv::GridStereoFrame> fused(match.participant(), topics::kFused,
                                                   tv::transport::frame_topic_qos());
  tv::transport::Writer<tv::DetectionArray> detections(match.participant(), topics::kDetections,
                                                       tv::transport::event_topic_qos());
  tv::transport::Reader<tv::MatchArray> matches(match.participant(), topics::kMatches,
                                                tv::transport::event_topic_qos());
  ASSERT_TRUE(match.ready(60s)) << match.log();
  ASSERT_TRUE(fused.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(detections.wait_for_readers(1, 10000ms));
  ASSERT_TRUE(matches.wait_for_writers(1, 10000ms));

  const cv::Size grid = pipeline_geometry().grid_size();
  const std::int64_t t0 = 1'700'000'000 * kSecond;
  const int shift = 9;
  std::uint64_t seq = 20;
  auto capture_of = [&](std::uint64_t s) { return t0 + static_cast<std::int64_t>(s) * 20'000'000; };
  auto send_frame = [&](const std::function<void(tv::GridStereoFrame&)>& corrupt) {
    return [&, corrupt] {
      auto loan = fused.loan();
      ++seq;
      fill_textured_pair(*loan, grid, shift, seq, capture_of(seq));
      corrupt(*loan);
      fused.publish(std::move(loan));
    };
  };
  match.expect_named("an unknown pixel format",
                     send_frame([](tv::GridStereoFrame& f) { f.pixel_format(9); }),
                     "unknown pixel format 9");
  match.expect_named("16-bit pixels in the fused band", send_frame([](tv::GridStereoFrame& f) {
                       f.pixel_format(tv::PIXEL_FORMAT_MONO16);
                       f.step(f.width() * 2);
                     }),
                     "16-bit pixels in an 8-bit band");
  match.expect_named("the left eye only",
                     send_frame([](tv::GridStereoFrame& f) { f.eyes(tv::EYES_LEFT); }),
                     "left eye only");
  match.expect_named("another grid",
                     send_frame([](tv::GridStereoFrame& f) { f.height(f.height() / 2); }),
                     "this service's grid is");
  match.expect_named("stages out of order", send_frame([](tv::GridStereoFrame& f) {
                       f.stamps(stamps({{tv::STAGE_MATCH, f.capture_time_ns() + 1000},
                                        {tv::STAGE_DETECT, f.capture_time_ns() + 2000}}));
                     }),
                     "stamps out of order");

  // A good frame, then detections for it: broken ones first.
  send_frame([](tv::GridStereoFrame&) {})();
  const std::uint64_t good = seq;
  auto send_detection = [&](tv::Box2D box) {
    return [&, box] {
      tv::DetectionArray a;
      a.frame_seq(good);
      a.capture_time_ns(capture_of(good));
      tv::Detection d;
      d.target_id(3);
      d.label("person");
      d.score(0.9f);
      d.box(box);
      a.detections().push_back(d);
      detections.write(a);
    };
  };
  match.expect_named("inf in a box", send_detection(box2d(400.f, 200.f, kInf, 60.f)),
                     "non-finite field");
  match.expect_named("a negative height", send_detection(box2d(400.f, 200.f, 40.f, -60.f)),
                     "box with no area");
  send_detection(box2d(400.f, 200.f, 40.f, 60.f))();
  std::optional<tv::MatchArray> answer;
  ASSERT_TRUE(receive<tv::MatchArray>(
      matches,
      [&](const tv::MatchArray& a) {
        if (a.frame_seq() == good) answer = a;
        return answer.has_value();
      },
      30s))
      << match.log();
  ASSERT_EQ(answer->targets().size(), 1u);
  ASSERT_GE(answer->targets()[0].points().size(), 10u);
  for (const tv::PointMatch& p : answer->targets()[0].points())
    EXPECT_NEAR(p.left_x() - p.right_x(), shift, 0.2);
  match.stop_and_check_log({"unknown pixel format 9", "non-finite field"});
}

// The supervisor's latency statistics come from thermovis/timing. A sample whose output is
// before its capture, whose latency is an hour, whose stamps are out of order or whose stage took
// longer than the frame is counted as a bad input and kept out of p50/p99, the late frames and
// the per-stage figures; the good samples around it are measured.
// A supervisor without services (only its readers are under test) on a private domain, and a
// participant to write to it.
struct SupervisorAlone {
  explicit SupervisorAlone(const std::string& name)
      : domain(tv::test::private_domain()),
        dir(tv::test::temp_dir(name)),
        supervised(tv::test::loopback_participant(domain, "supervisor")),
        supervisor(*supervised, tv::process::Manifest{name, {}}, config(dir)),
        participant(tv::test::loopback_participant(domain, "corrupt-test")) {}
  ~SupervisorAlone() { std::filesystem::remove_all(dir); }
  static tv::supervisor::SupervisorConfig config(const std::filesystem::path& dir) {
    tv::supervisor::SupervisorConfig c;
    c.log_dir = dir / "logs";
    return c;
  }
  int domain;
  std::filesystem::path dir;
  std::unique_ptr<tv::transport::Participant> supervised;
  tv::supervisor::Supervisor supervisor;
  std::unique_ptr<tv::transport::Participant> participant;
};

TEST(Corrupt, SupervisorCountsBadTimingAndKeepsItOutOfTheLatencies) {
  SupervisorAlone alone("corrupt_timing");
  tv::supervisor::Supervisor& supervisor = alone.supervisor;
  tv::transport::Writer<tv::FrameTiming> timing(*alone.participant, topics::kTiming,
                                                tv::transport::event_topic_qos(64));
  ASSERT_TRUE(timing.wait_for_readers(1, 20000ms));

  // Frame `seq` captured at c + seq s, through all five stages of 2 ms each, out after
  // `latency_ms`.
  const std::int64_t c = tv::transport::now_ns();
  const auto sample = [c](std::uint64_t seq, std::int64_t latency_ms) {
    tv::FrameTiming t;
    const std::int64_t capture = c + static_cast<std::int64_t>(seq) * kSecond;
    t.frame_seq(seq);
    t.capture_time_ns(capture);
    t.output_time_ns(capture + latency_ms * 1'000'000);
    const tv::Stage stages[] = {tv::STAGE_BRIDGE, tv::STAGE_RECTIFY_FUSE, tv::STAGE_DETECT,
                                tv::STAGE_MATCH, tv::STAGE_RANGE};
    for (std::size_t i = 0; i < 5; ++i) {
      t.stamps().stamps()[i].stage(stages[i]);
      t.stamps().stamps()[i].duration_us(2000);
      t.stamps().stamps()[i].end_ns(capture + static_cast<std::int64_t>(i + 1) * 2'000'000);
    }
    return t;
  };
  std::uint64_t seq = 0;
  for (const std::int64_t latency_ms : {10, 12, 14}) timing.write(sample(++seq, latency_ms));
  timing.write(sample(++seq, -5));         // output before capture
  timing.write(sample(++seq, 3'600'000));  // an hour
  auto disordered = sample(++seq, 25);     // would be a late frame
  disordered.stamps().stamps()[1].stage(tv::STAGE_MATCH);
  timing.write(disordered);
  auto long_stage = sample(++seq, 16);  // would dominate detect's figures
  long_stage.stamps().stamps()[2].duration_us(5'000'000);
  timing.write(long_stage);
  for (const std::int64_t latency_ms : {16, 18}) timing.write(sample(++seq, latency_ms));

  tv::supervisor::LatencySummary s;
  for (const auto until = std::chrono::steady_clock::now() + 20s;
       std::chrono::steady_clock::now() < until && s.frames + s.bad_timing < seq;) {
    supervisor.step();
    s = supervisor.summary();
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_EQ(s.bad_timing, 4u);
  EXPECT_EQ(s.bad_inputs, 4u);
  ASSERT_EQ(s.frames, 5u);
  EXPECT_DOUBLE_EQ(s.p50_ms, 14.0);
  EXPECT_DOUBLE_EQ(s.max_ms, 18.0);
  EXPECT_DOUBLE_EQ(s.p99_ms, 18.0);
  EXPECT_EQ(s.over_deadline, 0u);
  EXPECT_TRUE(supervisor.late_frames().empty());
  ASSERT_EQ(s.stages.size(), 5u);
  for (const auto& stage : s.stages) EXPECT_DOUBLE_EQ(stage.max_ms, 2.0) << stage.stage;
  // Each stage's output was ready 2 ms after the one before it, the first 2 ms after the capture.
  const std::map<std::string, double> done_ms = {
      {"bridge", 2.0}, {"rectify-fuse", 4.0}, {"detect", 6.0}, {"match", 8.0}, {"range", 10.0}};
  for (const auto& stage : s.stages) {
    EXPECT_DOUBLE_EQ(stage.done_p50_ms, done_ms.at(stage.stage)) << stage.stage;
    EXPECT_DOUBLE_EQ(stage.done_p99_ms, done_ms.at(stage.stage)) << stage.stage;
  }
}

// DEADLINE QoS misses come from the services' health, counted per service and topic (a late
// sample counts at its writer and at each reader) and since the last reset_statistics(), each
// at the time of the health that first counted it.
TEST(Corrupt, SupervisorCountsDeadlineMissesPerServiceAndTopic) {
  SupervisorAlone alone("deadline_misses");
  tv::supervisor::Supervisor& supervisor = alone.supervisor;
  tv::transport::Writer<tv::Health> health(*alone.participant, topics::kHealth,
                                           tv::transport::state_topic_qos());
  ASSERT_TRUE(health.wait_for_readers(1, 20000ms));
  const auto publish = [&](std::uint32_t visible_misses, std::uint32_t infrared_misses) {
    tv::Health h;
    h.service("thermovis-fake");
    h.state(tv::HEALTH_OK);
    h.time_ns(tv::transport::now_ns());
    tv::TopicHealth visible, infrared, ranges;
    visible.topic(topics::kRectifiedVisible);
    visible.requested_deadline_missed(visible_misses);
    infrared.topic(topics::kRectifiedInfrared);
    infrared.offered_deadline_missed(infrared_misses);
    ranges.topic(topics::kRanges);
    h.topics({visible, infrared, ranges});
    health.write(h);
    return h.time_ns();
  };
  const auto summary_when = [&](auto done) {
    tv::supervisor::LatencySummary s;
    for (const auto until = std::chrono::steady_clock::now() + 20s;
         std::chrono::steady_clock::now() < until && !done(s);) {
      supervisor.step();
      s = supervisor.summary();
      std::this_thread::sleep_for(10ms);
    }
    return s;
  };
  const std::int64_t first_ns = publish(2, 1);
  auto s = summary_when([](const auto& x) { return x.deadline_misses == 3; });
  EXPECT_EQ(s.deadline_misses, 3u);
  const std::string visible = std::string("thermovis-fake ") + topics::kRectifiedVisible;
  const std::string infrared = std::string("thermovis-fake ") + topics::kRectifiedInfrared;
  const auto events = [](const tv::supervisor::LatencySummary& x) {
    std::vector<std::tuple<std::int64_t, std::string, std::uint64_t>> out;
    for (const auto& e : x.deadline_miss_events) out.emplace_back(e.time_ns, e.endpoint, e.misses);
    return out;
  };
  using Events = std::vector<std::tuple<std::int64_t, std::string, std::uint64_t>>;
  EXPECT_EQ(events(s), (Events{{first_ns, visible, 2}, {first_ns, infrared, 1}}));
  EXPECT_EQ(s.deadline_misses_by_endpoint,
            (std::map<std::string, std::uint64_t>{{visible, 2}, {infrared, 1}}));
  EXPECT_NE(tv::supervisor::summary_text(s, 20.0).find(visible + " 2;"), std::string::npos)
      << tv::supervisor::summary_text(s, 20.0);
  supervisor.reset_statistics();
  const std::int64_t second_ns = publish(5, 1);
  s = summary_when([](const auto& x) { return x.deadline_misses == 3; });
  EXPECT_EQ(s.deadline_misses, 3u);
  EXPECT_EQ(s.deadline_misses_by_endpoint, (std::map<std::string, std::uint64_t>{{visible, 3}}));
  EXPECT_EQ(events(s), (Events{{second_ns, visible, 3}}));
  // A new process of the service counts from zero again: its first count is all new.
  const std::int64_t restarted_ns = publish(1, 0);
  s = summary_when([](const auto& x) { return x.deadline_miss_events.size() == 2; });
  EXPECT_EQ(events(s), (Events{{second_ns, visible, 3}, {restarted_ns, visible, 1}}));
}

}  // namespace
