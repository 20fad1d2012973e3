// The checks a service applies to what it receives beyond the image header: stage stamps and
// the order of frames (tests/integration/corrupt runs them in the services).
#include <gtest/gtest.h>

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
