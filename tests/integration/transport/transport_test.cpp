// Two real processes exchange VisibleStereoFrame (2 x 6.2 MB) through the loaned data-sharing
// path on a private DDS domain (loopback profile). The test asserts on what the receiving
// process found in the samples and where they lived in memory, not on console output.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"

namespace {

using thermovis::test::ChildProcess;
using namespace std::chrono_literals;

// A domain no other test process uses at the same time: ctest runs each case in its own
// process, so the pid tells them apart (domains 100..199, well inside the UDP port range).
using thermovis::test::private_domain;

struct FrameRun {
  nlohmann::json publisher, subscriber;
  std::set<std::string> segments;         // data-sharing segments the two processes mapped
  std::set<std::string> shm_left_behind;  // those still in /dev/shm after both exited
};

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) return {};
  return nlohmann::json::parse(in);
}

// Runs subscriber and publisher to completion; fails the test (and returns what it has) when
// either exits non-zero or overruns.
FrameRun run_frames(int count, int period_ms, int deadline_ms) {
  const auto dir = thermovis::test::temp_dir("transport");
  const std::string peer = (thermovis::test::bin_dir() / "transport_peer").string();
  const std::string domain = std::to_string(private_domain());
  {
    std::vector<std::string> common = {"--domain",      domain,
                                       "--count",       std::to_string(count),
                                       "--period-ms",   std::to_string(period_ms),
                                       "--deadline-ms", std::to_string(deadline_ms),
                                       "--timeout-s",   "60"};
    auto args = [&](const std::string& mode, const std::string& result) {
      std::vector<std::string> a = {peer, mode};
      a.insert(a.end(), common.begin(), common.end());
      a.insert(a.end(), {"--result", (dir / result).string()});
      return a;
    };
    ChildProcess subscriber(args("subscribe-frames", "sub.json"), dir / "sub.log");
    ChildProcess publisher(args("publish-frames", "pub.json"), dir / "pub.log");
    const auto sub_exit = subscriber.wait(90s);
    const auto pub_exit = publisher.wait(30s);
    EXPECT_EQ(sub_exit, 0) << "subscriber log:\n" << subscriber.log();
    EXPECT_EQ(pub_exit, 0) << "publisher log:\n" << publisher.log();
  }
  FrameRun run{read_json(dir / "pub.json"), read_json(dir / "sub.json"), {}, {}};
  // Each process listed the segments it had mapped (its own and its peer's) just before
  // shutting down; after clean exits none may remain. Leftovers are removed so that a failure
  // does not leak shared memory (only these: other tests may run beside this one).
  for (const auto* side : {&run.publisher, &run.subscriber}) {
    if (!side->contains("segments")) continue;
    for (const auto& path : (*side)["segments"]) run.segments.insert(path.get<std::string>());
  }
  for (const auto& path : run.segments) {
    if (std::filesystem::exists(path)) {
      run.shm_left_behind.insert(path);
      std::filesystem::remove(path);
    }
  }
  std::filesystem::remove_all(dir);
  return run;
}

TEST(TransportFrames, CrossProcessesZeroCopyAndIntact) {
  const int count = 10;
  const FrameRun run = run_frames(count, 100, 2000);
  ASSERT_TRUE(run.publisher.contains("frames"));
  ASSERT_TRUE(run.subscriber.contains("frames"));
  const auto& sent = run.publisher["frames"];
  const auto& received = run.subscriber["frames"];
  ASSERT_EQ(received.size(), static_cast<std::size_t>(count)) << "frames lost: " << received.dump();

  for (std::size_t i = 0; i < received.size(); ++i) {
    const auto& frame = received[i];
    SCOPED_TRACE("frame seq " + frame["seq"].dump());
    EXPECT_EQ(frame["seq"], i + 1);
    EXPECT_EQ(frame["pattern_errors"], 0) << "image words differ from what was written";
    EXPECT_EQ(frame["width"], 1920);
    EXPECT_EQ(frame["height"], 1080);
    EXPECT_TRUE(frame["still_valid"].get<bool>());
    // Zero-copy: the reader's sample is the very memory the writer loaned and filled: the same
    // offset of the same data-sharing segment file, mapped in both processes.
    const auto& writer_side = sent[i]["left"];
    const auto& reader_side = frame["left"];
    EXPECT_EQ(reader_side["path"].get<std::string>().rfind("/dev/shm/fast_datasharing", 0), 0u)
        << "reader sample not in a data-sharing segment: " << reader_side.dump();
    EXPECT_EQ(reader_side["path"], writer_side["path"]);
    EXPECT_EQ(reader_side["offset"], writer_side["offset"]);
  }
  // 100 ms between frames against a 2 s deadline: nothing may be reported.
  EXPECT_EQ(run.subscriber["counters"]["requested_deadline_missed"], 0);
  EXPECT_EQ(run.publisher["counters"]["offered_deadline_missed"], 0);
  EXPECT_EQ(run.publisher["counters"]["samples"], count);
  EXPECT_EQ(run.subscriber["counters"]["samples"], count);
}

TEST(TransportFrames, DeadlineMissesAreCounted) {
  // Frames every 100 ms against a 20 ms deadline: every gap spans at least 4 periods.
  const int count = 5;
  const FrameRun run = run_frames(count, 100, 20);
  ASSERT_TRUE(run.subscriber.contains("counters"));
  ASSERT_EQ(run.subscriber["frames"].size(), static_cast<std::size_t>(count));
  EXPECT_GE(run.subscriber["counters"]["requested_deadline_missed"].get<int>(), (count - 1) * 3);
  EXPECT_GE(run.publisher["counters"]["offered_deadline_missed"].get<int>(), (count - 1) * 3);
}

TEST(TransportFrames, ProcessesLeaveNoSharedMemoryBehind) {
  const FrameRun run = run_frames(3, 50, 2000);
  ASSERT_EQ(run.subscriber["frames"].size(), 3u);
  // The processes mapped the writer's pool (where the frames lived) and the reader's
  // notification segment ...
  EXPECT_GE(run.segments.size(), 2u);
  EXPECT_EQ(run.segments.count(run.publisher["frames"][0]["left"]["path"].get<std::string>()), 1u);
  // ... and their clean exits removed them all.
  EXPECT_TRUE(run.shm_left_behind.empty())
      << "left in /dev/shm: " << nlohmann::json(run.shm_left_behind).dump();
}

}  // namespace
