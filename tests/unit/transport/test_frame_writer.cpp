// Frame writers: a recreated writer reaches its readers again, a pool refused for longer than
// kStalledPoolRecovery makes the writer try a new one, and a reader that never takes a frame
// does not hold the writer back.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topic_types.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

namespace tt = thermovis::transport;
using namespace std::chrono_literals;
using Frame = thermovis::InfraredStereoFrame;

std::unique_ptr<tt::Participant> participant(const std::string& name) {
  tt::ParticipantConfig config;
  config.domain_id = thermovis::test::private_domain();
  config.profile = tt::kLoopbackProfile;
  config.profiles_file = tt::shipped_profile_file(config.profile);
  config.name = name;
  return std::make_unique<tt::Participant>(config);
}

void publish(tt::Writer<Frame>& writer, std::uint64_t seq) {
  auto loan = writer.loan();
  loan->seq(seq);
  writer.publish(std::move(loan));
}

// True once `reader` has taken the frame numbered `seq`; false after `timeout`.
bool receives(tt::Reader<Frame>& reader, std::uint64_t seq, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    reader.wait_for_data(50ms);
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i)
      if (samples[i].seq() == seq) return true;
  }
  return false;
}

TEST(FrameWriter, ARecreatedWriterReachesItsReadersAgain) {
  const auto p = participant("frame-writer-recreate");
  const std::string topic = "thermovis/test/recreate";
  tt::Writer<Frame> writer(*p, topic, tt::frame_topic_qos(0ns));
  tt::Reader<Frame> reader(*p, topic, tt::frame_topic_qos(0ns));
  ASSERT_TRUE(writer.wait_for_readers(1, 10s));
  publish(writer, 1);
  ASSERT_TRUE(receives(reader, 1, 5s));

  writer.recreate();
  ASSERT_TRUE(writer.wait_for_readers(1, 10s)) << "the reader never matched the new writer";
  publish(writer, 2);
  EXPECT_TRUE(receives(reader, 2, 5s));

  // Not while this process holds one of its samples: the error says so, the writer stays usable.
  {
    auto held = writer.loan();
    try {
      writer.recreate();
      ADD_FAILURE() << "recreated a writer with a sample on loan";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("loaned"), std::string::npos) << e.what();
    }
  }
  publish(writer, 3);
  EXPECT_TRUE(receives(reader, 3, 5s));
}

TEST(FrameWriter, ARefusedPoolTriesANewWriterPastTheRecoveryTime) {
  const auto p = participant("frame-writer-stall");
  const tt::TopicQos qos = tt::frame_topic_qos(0ns, 2, 1);
  tt::Writer<Frame> writer(*p, "thermovis/test/stall", qos);
  // Every slot on loan here: the pool refuses the next one.
  std::vector<tt::Loan<Frame>> held;
  for (int i = 0; i < qos.depth + qos.max_readers + 1; ++i) held.push_back(writer.loan());
  try {
    writer.loan();
    FAIL() << "a pool of " << held.size() << " slots lent one more";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("every pool slot"), std::string::npos) << e.what();
  }
  // Past the recovery time the writer tries a new pool; it cannot while these loans are out,
  // and says why.
  std::this_thread::sleep_for(tt::kStalledPoolRecovery + 100ms);
  try {
    writer.loan();
    FAIL() << "lent a slot while every one is held";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot recreate"), std::string::npos) << e.what();
  }
  EXPECT_EQ(writer.pool_recoveries(), 0u);
  held.clear();
  // Slots back: lending works again, without a recovery.
  EXPECT_NO_THROW(publish(writer, 1));
  EXPECT_EQ(writer.pool_recoveries(), 0u);
}

TEST(FrameWriter, AnObserverThatNeverTakesAFrameDoesNotHoldTheWriterBack) {
  const tt::TopicQos frames = tt::observer_qos(tt::frame_topic_qos());
  EXPECT_EQ(frames.deadline.count(), 0);
  EXPECT_EQ(tt::reader_qos(frames).deadline().period, eprosima::fastrtps::c_TimeInfinite);

  // An observer that never takes a frame, beside a reader that does: the writer publishes on,
  // never refused a slot (KEEP_LAST: a frame nobody took is replaced).
  const auto p = participant("frame-writer-observer");
  const std::string topic = "thermovis/test/observer";
  tt::Writer<Frame> writer(*p, topic, tt::frame_topic_qos(0ns));
  tt::Reader<Frame> observer(*p, topic, frames);
  tt::Reader<Frame> reader(*p, topic, tt::frame_topic_qos(0ns));
  ASSERT_TRUE(writer.wait_for_readers(2, 10s));
  for (std::uint64_t seq = 1; seq <= 20; ++seq) {
    ASSERT_NO_THROW(publish(writer, seq)) << "frame " << seq;
    EXPECT_TRUE(receives(reader, seq, 5s)) << "frame " << seq;
  }
  EXPECT_EQ(writer.pool_recoveries(), 0u);
}

}  // namespace
