// The checks a service applies to what it receives beyond the image header: stage stamps and
// the order of frames (tests/integration/corrupt runs them in the services).
#include <gtest/gtest.h>

#include <limits>
#include <memory>

#include "thermovis/node/frame_codec.hpp"

namespace tn = thermovis::node;
using Verdict = tn::FrameOrder::Verdict;

namespace {

thermovis::PipelineStamps stamps(
    std::initializer_list<std::pair<thermovis::Stage, std::int64_t>> s) {
  thermovis::PipelineStamps out;
  std::size_t i = 0;
  for (const auto& [stage, end_ns] : s) {
    out.stamps()[i].stage(stage);
    out.stamps()[i++].end_ns(end_ns);
  }
  return out;
}

std::string error_of(const thermovis::PipelineStamps& s, std::int64_t capture_ns) {
  try {
    tn::check_stamps(s, capture_ns, "frame 9");
    return "";
  } catch (const tn::FrameError& e) {
    return e.what();
  }
}

TEST(FrameChecks, StampsInPipelineOrderPass) {
  const std::int64_t c = 5'000'000'000;
  EXPECT_EQ(error_of(thermovis::PipelineStamps{}, c), "");
  EXPECT_EQ(error_of(stamps({{thermovis::STAGE_BRIDGE, c + 10},
                             {thermovis::STAGE_DETECT, c + 20},
                             {thermovis::STAGE_RANGE, c + 30}}),
                     c),
            "");
  // Stamps of another host may be a little behind this one's: within kStampSkewNs is accepted.
  EXPECT_EQ(error_of(stamps({{thermovis::STAGE_BRIDGE, c - tn::kStampSkewNs / 2}}), c), "");
}

TEST(FrameChecks, StampsOutOfOrderAreNamed) {
  const std::int64_t c = 5'000'000'000;
  using thermovis::STAGE_BRIDGE, thermovis::STAGE_DETECT, thermovis::STAGE_MATCH;
  EXPECT_NE(error_of(stamps({{STAGE_DETECT, c + 10}, {STAGE_BRIDGE, c + 20}}), c)
                .find("frame 9: stamp 1: stage 1 after stage 3 (stamps out of order)"),
            std::string::npos);
  EXPECT_NE(error_of(stamps({{STAGE_DETECT, c + 10}, {STAGE_DETECT, c + 20}}), c)
                .find("stage 3 after stage 3"),
            std::string::npos);
  EXPECT_NE(error_of(stamps({{77, c + 10}}), c).find("unknown stage 77"), std::string::npos);
  EXPECT_NE(error_of(stamps({{STAGE_BRIDGE, c - 3'000'000'000}}), c)
                .find("ends 3000 ms before the capture"),
            std::string::npos);
  EXPECT_NE(error_of(stamps({{STAGE_BRIDGE, c + 3'000'000'000}, {STAGE_MATCH, c + 10}}), c)
                .find("before stage 1"),
            std::string::npos);
  auto gap = stamps({{STAGE_BRIDGE, c + 10}});
  gap.stamps()[2].stage(STAGE_MATCH);
  gap.stamps()[2].end_ns(c + 30);
  EXPECT_NE(error_of(gap, c).find("stamp 2 follows an unused entry"), std::string::npos);
}

// A timing sample as thermovis-range publishes it: bridge, rectify-fuse, detect, match and
// range stamps of a frame captured at c, output at c + 30 ms.
thermovis::FrameTiming timing(std::int64_t c) {
  using namespace thermovis;
  thermovis::FrameTiming t;
  t.frame_seq(42);
  t.capture_time_ns(c);
  t.output_time_ns(c + 30'000'000);
  t.stamps(stamps({{STAGE_BRIDGE, c + 2'000'000},
                   {STAGE_RECTIFY_FUSE, c + 10'000'000},
                   {STAGE_DETECT, c + 20'000'000},
                   {STAGE_MATCH, c + 25'000'000},
                   {STAGE_RANGE, c + 29'000'000}}));
  for (auto& s : t.stamps().stamps()) s.duration_us(s.stage() == STAGE_NONE ? 0 : 2000);
  return t;
}

std::string timing_error(const thermovis::FrameTiming& t) {
  try {
    tn::check_timing(t);
    return "";
  } catch (const tn::FrameError& e) {
    return e.what();
  }
}

TEST(FrameChecks, TimingOfAPlausibleFramePasses) {
  const std::int64_t c = 5'000'000'000;
  EXPECT_EQ(timing_error(timing(c)), "");
  // A range stamp a little after the output (another host's clock) is within the skew.
  auto t = timing(c);
  t.stamps().stamps()[4].end_ns(c + 30'000'000 + tn::kStampSkewNs / 2);
  EXPECT_EQ(timing_error(t), "");
}

TEST(FrameChecks, ImpossibleTimingIsNamed) {
  const std::int64_t c = 5'000'000'000;
  auto before = timing(c);
  before.output_time_ns(c - 5'000'000);
  EXPECT_EQ(timing_error(before), "timing of frame 42: output 5 ms before the capture");

  auto long_ago = timing(c);
  long_ago.output_time_ns(c + 3600 * 1'000'000'000LL);
  EXPECT_NE(
      timing_error(long_ago).find("timing of frame 42: latency 3600000 ms, over the 10000 ms"),
      std::string::npos)
      << timing_error(long_ago);

  auto extreme = timing(std::numeric_limits<std::int64_t>::min());
  extreme.output_time_ns(std::numeric_limits<std::int64_t>::max());
  extreme.stamps(thermovis::PipelineStamps{});
  EXPECT_NE(timing_error(extreme).find("latency"), std::string::npos) << timing_error(extreme);

  auto stage_after_output = timing(c);
  stage_after_output.stamps().stamps()[4].end_ns(c + 3'000'000'000);
  EXPECT_EQ(timing_error(stage_after_output),
            "timing of frame 42: stage 5 ends 2970 ms after the output");

  auto long_stage = timing(c);
  long_stage.stamps().stamps()[1].duration_us(4'000'000);
  EXPECT_EQ(timing_error(long_stage),
            "timing of frame 42: stage 2 took 4000 ms, longer than the frame's 30 ms latency");

  // The stamp checks every received frame gets apply too.
  auto disordered = timing(c);
  disordered.stamps().stamps()[1].stage(thermovis::STAGE_MATCH);
  EXPECT_NE(timing_error(disordered).find("timing of frame 42: stamp 2: stage 3 after stage 4"),
            std::string::npos)
      << timing_error(disordered);
}

TEST(FrameChecks, FrameOrderTellsRepeatedStaleAndRestartedWriters) {
  tn::FrameOrder order;
  EXPECT_EQ(order.check(10, 1000), Verdict::next);
  EXPECT_EQ(order.check(11, 1020), Verdict::next);
  EXPECT_EQ(order.check(11, 1020), Verdict::repeated);
  EXPECT_EQ(order.check(8, 960), Verdict::stale);  // an older capture, late
  EXPECT_EQ(order.last_seq(), 11u);
  EXPECT_EQ(order.check(1, 5000), Verdict::restarted);  // counts again, later captures
  EXPECT_EQ(order.last_seq(), 1u);
  EXPECT_EQ(order.check(2, 5020), Verdict::next);
}

TEST(FrameChecks, AStepOtherThanThePackedRowIsNamed) {
  auto frame = std::make_unique<thermovis::InfraredStereoFrame>();
  tn::prepare(*frame, tn::Eye::left, {640, 480});
  EXPECT_EQ(frame->step(), 1280u);
  frame->step(1344);  // padded rows: not what the type carries
  try {
    tn::view(*frame, tn::Eye::left);
    FAIL() << "a padded step was accepted";
  } catch (const tn::FrameError& e) {
    EXPECT_NE(std::string(e.what()).find("step 1344 bytes, the packed rows of a 640x480 image are "
                                         "1280"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
