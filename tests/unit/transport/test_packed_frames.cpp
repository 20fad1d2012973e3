// Frame topics' packed twins (transport/frames.hpp): packing keeps the header and exactly the
// image's bytes, unpacking refuses what does not fit with an error naming it, a FrameWriter
// fills the twin only while a reader of it is matched, and a FrameReader of the twin hands out
// the plain frame byte for byte, leaving a malformed sample out without losing the next.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/test/data.hpp"
#include "thermovis/transport/frames.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"

namespace {

namespace tt = thermovis::transport;
using namespace std::chrono_literals;
using thermovis::GridStereoFrame;
using thermovis::PackedStereoFrame;

// A grid frame of the pipeline grid's visible size (MONO8) whose bytes follow `seq`.
std::unique_ptr<GridStereoFrame> grid_frame(std::uint64_t seq, thermovis::EyeSet eyes) {
  auto f = std::make_unique<GridStereoFrame>();
  f->seq(seq);
  f->capture_time_ns(1000 + static_cast<std::int64_t>(seq));
  f->pixel_format(thermovis::PIXEL_FORMAT_MONO8);
  f->width(936);
  f->height(566);
  f->step(936);
  f->eyes(eyes);
  f->geometry_id(77);
  f->stamps().stamps()[0].stage(thermovis::STAGE_RECTIFY_FUSE);
  f->stamps().stamps()[0].end_ns(5);
  for (std::size_t i = 0; i < 936u * 566u; ++i) {
    f->left()[i] = static_cast<std::uint8_t>(i * 7 + seq);
    f->right()[i] = static_cast<std::uint8_t>(i * 13 + seq);
  }
  return f;
}

// The image bytes and header of `a` and `b` agree (the right eye only with EYES_BOTH).
void expect_same(const GridStereoFrame& a, const GridStereoFrame& b) {
  EXPECT_EQ(a.seq(), b.seq());
  EXPECT_EQ(a.capture_time_ns(), b.capture_time_ns());
  EXPECT_EQ(a.pixel_format(), b.pixel_format());
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.step(), b.step());
  EXPECT_EQ(a.eyes(), b.eyes());
  EXPECT_EQ(a.geometry_id(), b.geometry_id());
  EXPECT_EQ(a.stamps().stamps()[0].stage(), b.stamps().stamps()[0].stage());
  EXPECT_EQ(a.stamps().stamps()[0].end_ns(), b.stamps().stamps()[0].end_ns());
  const std::size_t bytes = static_cast<std::size_t>(a.height()) * a.step();
  EXPECT_TRUE(std::equal(a.left().begin(), a.left().begin() + bytes, b.left().begin()));
  if (a.eyes() == thermovis::EYES_BOTH) {
    EXPECT_TRUE(std::equal(a.right().begin(), a.right().begin() + bytes, b.right().begin()));
  }
}

// The message of what unpack() throws, or "" when it does not.
std::string unpack_error(const PackedStereoFrame& packed) {
  auto to = std::make_unique<GridStereoFrame>();
  try {
    tt::unpack(packed, *to);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(PackedFrames, CarryTheHeaderAndTheImageBytesOnly) {
  const auto both = grid_frame(3, thermovis::EYES_BOTH);
  PackedStereoFrame packed;
  tt::pack(*both, packed);
  EXPECT_EQ(packed.left().size(), 936u * 566u);
  EXPECT_EQ(packed.right().size(), 936u * 566u);
  auto back = std::make_unique<GridStereoFrame>();
  tt::unpack(packed, *back);
  expect_same(*both, *back);

  const auto left = grid_frame(4, thermovis::EYES_LEFT);
  tt::pack(*left, packed);  // reused: the right eye empties
  EXPECT_EQ(packed.left().size(), 936u * 566u);
  EXPECT_TRUE(packed.right().empty());
  tt::unpack(packed, *back);
  expect_same(*left, *back);

  // Raw frames: both eyes, 16-bit counts as little-endian bytes.
  auto ir = std::make_unique<thermovis::InfraredStereoFrame>();
  ir->seq(9);
  ir->pixel_format(thermovis::PIXEL_FORMAT_MONO16);
  ir->width(640);
  ir->height(512);
  ir->step(1280);
  for (std::size_t i = 0; i < 640u * 512u; ++i) ir->left()[i] = static_cast<std::uint16_t>(i);
  tt::pack(*ir, packed);
  EXPECT_EQ(packed.left().size(), 1280u * 512u);
  EXPECT_EQ(packed.eyes(), thermovis::EYES_BOTH);
  auto ir_back = std::make_unique<thermovis::InfraredStereoFrame>();
  tt::unpack(packed, *ir_back);
  EXPECT_EQ(ir_back->left()[640u * 511u + 5], static_cast<std::uint16_t>(640u * 511u + 5));
  EXPECT_EQ(ir_back->step(), 1280u);
}

TEST(PackedFrames, UnpackingRefusesWhatDoesNotFitNamingIt) {
  const auto frame = grid_frame(1, thermovis::EYES_BOTH);
  PackedStereoFrame packed;
  tt::pack(*frame, packed);

  PackedStereoFrame short_left = packed;
  short_left.left().resize(100);
  EXPECT_NE(unpack_error(short_left).find("left eye holds 100 bytes"), std::string::npos)
      << unpack_error(short_left);

  PackedStereoFrame no_right = packed;
  no_right.right().clear();
  EXPECT_NE(unpack_error(no_right).find("right eye holds 0 bytes"), std::string::npos)
      << unpack_error(no_right);

  PackedStereoFrame too_large = packed;
  too_large.height(5000);
  too_large.step(3000);
  EXPECT_NE(unpack_error(too_large).find("does not fit"), std::string::npos)
      << unpack_error(too_large);

  // A raw frame type has both eyes.
  PackedStereoFrame left_only = packed;
  left_only.eyes(thermovis::EYES_LEFT);
  left_only.right().clear();
  auto visible = std::make_unique<thermovis::VisibleStereoFrame>();
  EXPECT_THROW(tt::unpack(left_only, *visible), std::invalid_argument);
  // Packing a header whose image exceeds the plain frame.
  auto bad = grid_frame(2, thermovis::EYES_BOTH);
  bad->height(100000);
  EXPECT_THROW(tt::pack(*bad, packed), std::invalid_argument);
}

std::unique_ptr<tt::Participant> participant(const std::string& name, int domain,
                                             tt::FrameTransport frames) {
  tt::ParticipantConfig config;
  config.domain_id = domain;
  config.profile = tt::kLoopbackProfile;
  config.profiles_file = tt::shipped_profile_file(config.profile);
  config.name = name;
  config.frame_transport = frames;
  return std::make_unique<tt::Participant>(config);
}

// Takes from `reader` until a frame numbered `seq` arrives (then returns a copy) or `timeout`.
std::unique_ptr<GridStereoFrame> receive(tt::FrameReader<GridStereoFrame>& reader,
                                         std::uint64_t seq, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    reader.wait_for_data(50ms);
    auto frames = reader.take();
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (frames[i].seq() != seq) continue;
      auto copy = std::make_unique<GridStereoFrame>();
      *copy = frames[i];
      return copy;
    }
  }
  return nullptr;
}

void publish(tt::FrameWriter<GridStereoFrame>& writer, const GridStereoFrame& frame) {
  auto loan = writer.loan();
  *loan = frame;
  writer.publish(std::move(loan));
}

TEST(PackedFrames, TheTwinIsWrittenOnlyForItsReadersAndReadAsThePlainFrame) {
  const int domain = thermovis::test::private_domain();
  const auto writing = participant("packed-writer", domain, tt::FrameTransport::plain);
  const std::string topic = "thermovis/test/packed";
  tt::FrameWriter<GridStereoFrame> writer(*writing, topic, tt::frame_topic_qos(0ns));
  const auto local = participant("packed-plain-reader", domain, tt::FrameTransport::plain);
  tt::FrameReader<GridStereoFrame> plain(*local, topic, tt::frame_topic_qos(0ns));
  EXPECT_FALSE(plain.packed());
  ASSERT_TRUE(writer.wait_for_readers(1, 10s));

  // Only a plain reader: the twin is not written.
  const auto first = grid_frame(1, thermovis::EYES_BOTH);
  publish(writer, *first);
  const auto got_plain = receive(plain, 1, 5s);
  ASSERT_NE(got_plain, nullptr);
  expect_same(*first, *got_plain);
  EXPECT_EQ(writer.packed_counters().samples, 0u);

  // A reader of the twin: frames reach it unpacked, byte for byte.
  std::vector<std::string> bad;
  const auto remote = participant("packed-reader", domain, tt::FrameTransport::packed);
  tt::FrameReader<GridStereoFrame> packed(*remote, topic, tt::frame_topic_qos(0ns),
                                          [&bad](const std::string& why) { bad.push_back(why); });
  EXPECT_TRUE(packed.packed());
  EXPECT_EQ(packed.topic_name(), topic + "/packed");
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (writer.readers() < 2 && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(10ms);
  ASSERT_EQ(writer.readers(), 2u);
  const auto second = grid_frame(2, thermovis::EYES_LEFT);
  publish(writer, *second);
  const auto got_packed = receive(packed, 2, 5s);
  ASSERT_NE(got_packed, nullptr);
  expect_same(*second, *got_packed);
  EXPECT_EQ(writer.packed_counters().samples, 1u);

  // A malformed sample on the twin (another application's writer) is left out and named; the
  // next frame still comes.
  tt::Writer<PackedStereoFrame> stranger(*writing, topic + "/packed",
                                         tt::packed_twin_qos(tt::frame_topic_qos(0ns)));
  ASSERT_TRUE(stranger.wait_for_readers(1, 10s));
  PackedStereoFrame broken;
  tt::pack(*grid_frame(3, thermovis::EYES_BOTH), broken);
  broken.left().resize(10);
  stranger.write(broken);
  publish(writer, *grid_frame(4, thermovis::EYES_BOTH));
  const auto after = receive(packed, 4, 5s);
  ASSERT_NE(after, nullptr);
  // The two writers' samples may come in either order.
  for (const auto until_bad = std::chrono::steady_clock::now() + 5s;
       bad.empty() && std::chrono::steady_clock::now() < until_bad;) {
    packed.wait_for_data(50ms);
    packed.take();
  }
  ASSERT_EQ(bad.size(), 1u);
  EXPECT_NE(bad[0].find("frame 3: left eye holds 10 bytes"), std::string::npos) << bad[0];
  EXPECT_EQ(packed.bad_frames(), 1u);
}

}  // namespace
