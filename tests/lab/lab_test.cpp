// The pipeline split over three hosts of a lab (network namespaces linked through a switch,
// deploy/lab/lab.sh): the bridge and rectify-fuse on host a, detect, match and range on host b,
// and this test's own DDS reader of thermovis/ranges on host c. Nothing but the lab's links
// joins the hosts (each has its own addresses, so Fast DDS sees three machines and uses UDP
// between them; shared memory and data-sharing only within one). The ranges must be those of
// one host (same tolerance against the simulated truth as tests/integration/pipeline), and
// must come back after a cable is cut and restored. The per-hop latencies over the lab's links
// (from the stamps every message carries; the namespaces share one clock) and the bytes that
// crossed host a's link are printed and recorded as test properties.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "../integration/pipeline/range_truth.hpp"
#include "lab_harness.hpp"
#include "thermovis/frames.h"
#include "thermovis/metrics/percentile.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using thermovis::metrics::percentile;
using thermovis::test::ChildProcess;
using thermovis::test::Lab;
namespace tv = thermovis;

// The pipeline's services, each on its lab host, stopped downstream first (a reader before the
// writer it reads from).
class SplitPipeline {
 public:
  SplitPipeline(const Lab& lab, const std::filesystem::path& dir, int domain,
                const std::string& profile, const std::map<std::string, std::string>& env = {}) {
    const auto bin = thermovis::test::bin_dir();
    const auto scene = thermovis::test::source_root() / "deploy/scenes/paper.yaml";
    const std::vector<std::string> dds{"--domain", std::to_string(domain), "--profile", profile};
    // Host b reads the frames' packed twins (the pixels only); THERMOVIS_LAB_FRAMES=plain
    // measures the plain types across the link instead.
    const char* frames = std::getenv("THERMOVIS_LAB_FRAMES");
    const std::string b_frames = frames != nullptr ? frames : "packed";
    auto start = [&](const std::string& host, const std::string& service,
                     std::vector<std::string> extra) {
      std::vector<std::string> argv{(bin / service).string()};
      argv.insert(argv.end(), dds.begin(), dds.end());
      if (host == "b") {
        argv.push_back("--frame-transport");
        argv.push_back(b_frames);
      }
      argv.insert(argv.end(), extra.begin(), extra.end());
      services_.push_back({service, lab.start(host, argv, dir / (service + ".log"), env)});
    };
    // 25 captures a second (THERMOVIS_LAB_RATE to measure others): each crosses a->b as the
    // rectified pairs' packed twins, the visible one to match and the infrared one to detect
    // and to match (5.3 MB a capture on the pipeline grid, 133 MB/s). As plain types the two
    // pairs were 13.1 MB each per reader, and 5 Hz was what the link carried.
    const char* rate = std::getenv("THERMOVIS_LAB_RATE");
    start("a", "thermovis-bridge",
          {"--source", "sim", "--scene", scene.string(), "--prerender", "10", "--rate",
           rate != nullptr ? rate : "25"});
    start("a", "thermovis-rectify-fuse", {});
    start("b", "thermovis-detect", {});
    start("b", "thermovis-match", {});
    start("b", "thermovis-range", {});
  }
  ~SplitPipeline() { stop(); }

  // SIGTERM downstream first; the exit codes by service (-1: killed after the timeout).
  std::map<std::string, int> stop() {
    std::map<std::string, int> codes;
    for (auto it = services_.rbegin(); it != services_.rend(); ++it) {
      if (!it->process) continue;
      it->process->signal(SIGTERM);
      codes[it->name] = it->process->wait(30s).value_or(-1);
      it->process.reset();
    }
    return codes;
  }

  std::string logs() const {
    std::string all;
    for (const auto& s : services_) {
      if (!s.process) continue;
      std::string log = s.process->log();
      if (log.size() > 3000) log = "..." + log.substr(log.size() - 3000);
      all += "---- " + s.name + "\n" + log;
    }
    return all;
  }

 private:
  struct Service {
    std::string name;
    std::unique_ptr<ChildProcess> process;
  };
  std::vector<Service> services_;
};

// Latencies of one result's path, ms: each stage's processing and each hop between stages
// (from one stage's end to the next one's start: transport plus waiting), and the last hop to
// the consumer that received it at `received_ns`.
struct PathLatency {
  std::map<std::string, std::vector<double>> ms;

  void add(const tv::PipelineStamps& stamps, std::int64_t capture_ns, std::int64_t received_ns) {
    static const std::map<tv::Stage, std::string> names{{tv::STAGE_BRIDGE, "bridge"},
                                                        {tv::STAGE_RECTIFY_FUSE, "rectify-fuse"},
                                                        {tv::STAGE_DETECT, "detect"},
                                                        {tv::STAGE_MATCH, "match"},
                                                        {tv::STAGE_RANGE, "range"}};
    std::string previous = "capture";
    std::int64_t previous_end = capture_ns;
    for (const tv::StageStamp& s : stamps.stamps()) {
      if (s.stage() == tv::STAGE_NONE) break;
      const auto name = names.count(s.stage()) ? names.at(s.stage()) : "stage?";
      const std::int64_t start = s.end_ns() - static_cast<std::int64_t>(s.duration_us()) * 1000;
      if (previous != "capture")
        ms[previous + " -> " + name].push_back((start - previous_end) / 1e6);
      ms[name].push_back(s.duration_us() / 1e3);
      previous = name;
      previous_end = s.end_ns();
    }
    ms[previous + " -> consumer"].push_back((received_ns - previous_end) / 1e6);
    ms["capture -> consumer"].push_back((received_ns - capture_ns) / 1e6);
  }

  std::string table() const {
    std::ostringstream out;
    out << std::fixed << std::setprecision(1);
    for (const auto& [name, values] : ms) {
      out << "  " << std::setw(28) << std::left << name << std::right << " p50 " << std::setw(7)
          << percentile(values, 50) << " ms  p99 " << std::setw(7) << percentile(values, 99)
          << " ms  (" << values.size() << ")\n";
    }
    return out.str();
  }
};

// Range results received at the consumer, checked against the simulated truth.
class RangeCheck {
 public:
  explicit RangeCheck(tv::transport::Reader<tv::RangeArray>& reader) : reader_(reader) {}

  // Takes results until `until` or until `wanted` arrays with targets arrived (0: until `until`);
  // returns how many arrays with targets came.
  int collect(Clock::time_point until, int wanted, bool check = true) {
    int got = 0;
    while (Clock::now() < until && (wanted == 0 || got < wanted)) {
      reader_.wait_for_data(100ms);
      auto samples = reader_.take();
      const std::int64_t received_ns = tv::transport::now_ns();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const tv::RangeArray& a = samples[i];
        if (a.targets().empty()) continue;
        ++got;
        last_ = Clock::now();
        if (!check) continue;
        latency_.add(a.stamps(), a.capture_time_ns(), received_ns);
        truth_.add(a);
        first_seq_ = std::min(first_seq_, a.frame_seq());
        last_seq_ = std::max(last_seq_, a.frame_seq());
      }
    }
    return got;
  }

  // As on one host (tests/integration/pipeline): each person within 6 % of the truth.
  void expect_like_one_host(int people) const { truth_.expect_like_truth(people); }

  std::size_t arrays() const { return truth_.arrays(); }
  // Captures made from the first checked result's to the last one's.
  std::uint64_t captures() const { return arrays() > 0 ? last_seq_ - first_seq_ + 1 : 0; }
  // The share of those captures answered.
  double answered_share() const {
    return captures() > 0 ? static_cast<double>(arrays()) / static_cast<double>(captures()) : 0.0;
  }
  Clock::time_point last() const { return last_; }
  const PathLatency& latency() const { return latency_; }

 private:
  tv::transport::Reader<tv::RangeArray>& reader_;
  thermovis::test::RangeTruth truth_;
  Clock::time_point last_{};
  PathLatency latency_;
  std::uint64_t first_seq_ = std::numeric_limits<std::uint64_t>::max();
  std::uint64_t last_seq_ = 0;
};

std::unique_ptr<tv::transport::Participant> participant_on_lab(int domain,
                                                               const std::string& profile) {
  tv::transport::ParticipantConfig pc;
  pc.domain_id = domain;
  pc.profile = profile;
  pc.profiles_file = tv::transport::shipped_profile_file(profile);
  pc.name = "lab-consumer";
  return std::make_unique<tv::transport::Participant>(pc);
}

// This test as the consumer on host c of `lab`: its participant and its reader of the ranges
// are made in c's namespace (their sockets are c's).
struct ConsumerOnC {
  ConsumerOnC(const Lab& lab, int domain) {
    const thermovis::test::NetnsScope on_c(lab.ns("c"));
    participant = participant_on_lab(domain, tv::transport::kUdpProfile);
    ranges = std::make_unique<tv::transport::Reader<tv::RangeArray>>(
        *participant, tv::transport::topics::kRanges, tv::transport::event_topic_qos(64));
  }
  std::unique_ptr<tv::transport::Participant> participant;
  std::unique_ptr<tv::transport::Reader<tv::RangeArray>> ranges;
};

// Collects checked results for `window`; returns what host a sent meanwhile, Mbit/s, and the
// window's length in `seconds`.
double collect_measuring_link(const Lab& lab, RangeCheck& check, std::chrono::seconds window,
                              double& seconds) {
  const std::uint64_t tx0 = lab.tx_bytes("a");
  const auto t0 = Clock::now();
  check.collect(t0 + window, 0);
  seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return static_cast<double>(lab.tx_bytes("a") - tx0) * 8 / 1e6 / seconds;
}

TEST(Lab, PipelineOverThreeHostsRangesAsOnOneHostAndComesBackAfterALinkCut) {
  const auto dir = thermovis::test::temp_dir("lab");
  std::string why;
  const auto lab = Lab::make({"a", "b", "c"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  // Measurement knob: host a's link limited like a real one (e.g. 1gbit).
  if (const char* rate = std::getenv("THERMOVIS_LAB_LINK_RATE")) lab->shape("a", {"--rate", rate});
  const int domain = thermovis::test::private_domain();
  ConsumerOnC consumer(*lab, domain);
  SplitPipeline pipeline(*lab, dir, domain, tv::transport::kUdpProfile);
  RangeCheck check(*consumer.ranges);

  // First results (services start, discover each other over the lab, make their maps).
  ASSERT_GE(check.collect(Clock::now() + 120s, 1, false), 1) << "no ranges reached host c\n"
                                                             << pipeline.logs();
  // Then 10 s of results, and what crossed host a's link meanwhile.
  double seconds = 0;
  const double a_mbit_s = collect_measuring_link(*lab, check, 10s, seconds);
  std::cout << check.arrays() << " range arrays at host c in " << seconds << " s ("
            << check.arrays() / seconds << " /s) of " << check.captures()
            << " captures; host a sent " << a_mbit_s << " Mbit/s\n"
            << "latency per stage and hop:\n"
            << check.latency().table();
  RecordProperty("ranges_per_s", std::to_string(check.arrays() / seconds));
  RecordProperty("results_of_captures", std::to_string(check.answered_share()));
  RecordProperty("host_a_link_mbit_s", std::to_string(a_mbit_s));
  for (const auto& [name, values] : check.latency().ms)
    RecordProperty(name + " p50_ms", std::to_string(percentile(values, 50)));
  ASSERT_GE(check.arrays(), 15u) << pipeline.logs();
  check.expect_like_one_host(4);

  // Host b's cable is cut for 4 s: frames from a and ranges to c stop (proof that they went
  // over the lab's links, not through shared memory), then resume.
  lab->link("b", false);
  const auto cut = Clock::now();
  check.collect(cut + 1s, 0, false);  // results already past the cut
  const int during = check.collect(cut + 4s, 0, false);
  EXPECT_EQ(during, 0) << "ranges arrived at c while b was cut off";
  lab->link("b", true);
  const auto restored = Clock::now();
  ASSERT_GE(check.collect(restored + 90s, 1, false), 1)
      << "no ranges within 90 s after the link came back\n"
      << pipeline.logs();
  const double outage_s = std::chrono::duration<double>(check.last() - restored).count();
  std::cout << "link of b restored: ranges at c again after " << outage_s << " s\n";
  RecordProperty("ranges_again_after_link_up_s", std::to_string(outage_s));
  EXPECT_GE(check.collect(Clock::now() + 30s, 5, false), 5) << "ranges did not keep flowing";

  for (const auto& [service, code] : pipeline.stop()) EXPECT_EQ(code, 0) << service;
  std::filesystem::remove_all(dir);
}

// Host a's link limited to 1 Gbit/s (tc), as a real port: the packed twins of the rectified
// pairs, each sent once to host b's readers (multicast), fit it at 25 captures a second
// (about 700 Mbit/s); the plain types took 1.8 Gbit/s at 5 (docs/deployment.md). The ranges are
// those of one host; the share of captures answered and the latency are printed.
TEST(Lab, PipelineOverThreeHostsOnAGigabitLink) {
  const auto dir = thermovis::test::temp_dir("lab-gbit");
  std::string why;
  const auto lab = Lab::make({"a", "b", "c"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  lab->shape("a", {"--rate", "1gbit"});
  const int domain = thermovis::test::private_domain();
  ConsumerOnC consumer(*lab, domain);
  SplitPipeline pipeline(*lab, dir, domain, tv::transport::kUdpProfile);
  RangeCheck check(*consumer.ranges);
  ASSERT_GE(check.collect(Clock::now() + 120s, 1, false), 1) << "no ranges reached host c\n"
                                                             << pipeline.logs();
  check.collect(Clock::now() + 3s, 0, false);  // past the start
  double seconds = 0;
  const double a_mbit_s = collect_measuring_link(*lab, check, 10s, seconds);
  std::cout << check.arrays() << " of " << check.captures() << " captures answered at host c over "
            << "a 1 Gbit/s link; host a sent " << a_mbit_s << " Mbit/s\n"
            << check.latency().table();
  RecordProperty("results_of_captures", std::to_string(check.answered_share()));
  RecordProperty("host_a_link_mbit_s", std::to_string(a_mbit_s));
  ASSERT_GE(check.arrays(), 15u) << pipeline.logs();
  check.expect_like_one_host(4);
  for (const auto& [service, code] : pipeline.stop()) EXPECT_EQ(code, 0) << service;
  std::filesystem::remove_all(dir);
}

// Without multicast (no multicast route on any host), discovery through a Fast DDS discovery
// server on host a: every participant, this test's included, is a client of it.
TEST(Lab, PipelineOverThreeHostsWithADiscoveryServerAndNoMulticast) {
  const auto dir = thermovis::test::temp_dir("lab-ds");
  std::string why;
  const auto lab = Lab::make({"a", "b", "c"}, false, why);
  if (!lab) GTEST_SKIP() << why;
  const int domain = thermovis::test::private_domain();
  // A port of this test's own (the server is not bound to a domain).
  const std::string server = lab->ip("a") + ":" + std::to_string(11811 + domain);
  auto discovery_server = lab->start("a",
                                     {"/usr/bin/env", "fastdds", "discovery", "-i", "0", "-l",
                                      lab->ip("a"), "-p", std::to_string(11811 + domain)},
                                     dir / "discovery-server.log");
  const std::map<std::string, std::string> env{{"ROS_DISCOVERY_SERVER", server}};
  const thermovis::test::NetnsScope on_c(lab->ns("c"));
  ::setenv("ROS_DISCOVERY_SERVER", server.c_str(), 1);
  const auto participant = participant_on_lab(domain, tv::transport::kDiscoveryProfile);
  tv::transport::Reader<tv::RangeArray> ranges(*participant, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  SplitPipeline pipeline(*lab, dir, domain, tv::transport::kDiscoveryProfile, env);
  RangeCheck check(ranges);
  ASSERT_GE(check.collect(Clock::now() + 120s, 1, false), 1)
      << "no ranges reached host c through the discovery server\n"
      << pipeline.logs() << "---- discovery server\n"
      << discovery_server->log();
  const auto t0 = Clock::now();
  check.collect(t0 + 8s, 0);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  std::cout << check.arrays() << " range arrays at host c in " << seconds << " s\n"
            << check.latency().table();
  ASSERT_GE(check.arrays(), 8u) << pipeline.logs();
  check.expect_like_one_host(4);
  for (const auto& [service, code] : pipeline.stop()) EXPECT_EQ(code, 0) << service;
  discovery_server->signal(SIGTERM);
  discovery_server->wait(10s);
  ::unsetenv("ROS_DISCOVERY_SERVER");
  std::filesystem::remove_all(dir);
}

// Raw visible frames (12.4 MB samples) from the bridge on host a, read on host b across the lab
// link, paced by the flow controller of thermovis_udp_paced (115 MB/s): at 5 captures a second
// (62 MB/s) they arrive whole and in capture order. The rate of frames that got through and
// their one-hop latency are printed. Measurement knobs: THERMOVIS_LAB_PROFILE (thermovis_udp:
// synchronous sending), THERMOVIS_LAB_FRAME_RATE (offered captures per second; above the
// flow controller's limit the paced profile delivers none, docs/deployment.md, lab).
TEST(Lab, RawFramesCrossALinkWholeAndInOrder) {
  std::string why;
  const auto lab = Lab::make({"a", "b"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  const auto dir = thermovis::test::temp_dir("lab-frames");
  const int domain = thermovis::test::private_domain();
  const char* profile_env = std::getenv("THERMOVIS_LAB_PROFILE");
  const std::string profile =
      profile_env != nullptr ? profile_env : tv::transport::kUdpPacedProfile;
  const char* frame_rate = std::getenv("THERMOVIS_LAB_FRAME_RATE");
  const thermovis::test::NetnsScope on_b(lab->ns("b"));
  const auto participant = participant_on_lab(domain, profile);
  tv::transport::Reader<tv::VisibleStereoFrame> frames(
      *participant, tv::transport::topics::kVisibleFrames, tv::transport::frame_topic_qos());
  const auto scene = thermovis::test::source_root() / "deploy/scenes/paper.yaml";
  auto bridge = lab->start(
      "a",
      {(thermovis::test::bin_dir() / "thermovis-bridge").string(), "--domain",
       std::to_string(domain), "--profile", profile, "--source", "sim", "--scene", scene.string(),
       "--prerender", "4", "--rate", frame_rate != nullptr ? frame_rate : "5"},
      dir / "bridge.log");
  ASSERT_TRUE(frames.wait_for_writers(1, 60000ms)) << bridge->log();
  std::uint64_t received = 0, first_seq = 0, last_seq = 0;
  bool ordered = true;
  std::vector<double> hop_ms;
  auto take = [&](Clock::time_point until) {
    while (Clock::now() < until) {
      frames.wait_for_data(100ms);
      auto samples = frames.take();
      const std::int64_t now = tv::transport::now_ns();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const tv::VisibleStereoFrame& f = samples[i];
        ASSERT_EQ(f.width(), 1920u);
        ASSERT_EQ(f.height(), 1080u);
        ASSERT_EQ(f.pixel_format(), tv::PIXEL_FORMAT_BGR8);
        // A rendered scene, not an empty buffer: the first and last rows differ (sky, ground).
        const std::size_t row = f.step();
        ASSERT_FALSE(std::equal(f.left().begin(), f.left().begin() + row,
                                f.left().begin() + row * (f.height() - 1)));
        if (received > 0 && f.seq() <= last_seq) ordered = false;
        if (received == 0) first_seq = f.seq();
        last_seq = f.seq();
        ++received;
        const auto& bridge_stamp = f.stamps().stamps()[0];
        if (bridge_stamp.stage() == tv::STAGE_BRIDGE)
          hop_ms.push_back((now - bridge_stamp.end_ns()) / 1e6);
      }
    }
  };
  take(Clock::now() + 2s);  // the first frames, while the writer ramps up
  received = 0;
  hop_ms.clear();
  const std::uint64_t tx0 = lab->tx_bytes("a");
  const auto t0 = Clock::now();
  take(t0 + 6s);
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  const double mbit_s = static_cast<double>(lab->tx_bytes("a") - tx0) * 8 / 1e6 / seconds;
  const double captured = received > 0 ? static_cast<double>(last_seq - first_seq + 1) : 0.0;
  std::cout << profile << ": " << received << " of " << captured << " raw visible frames ("
            << received / seconds << " /s, " << received * 12.44 / seconds
            << " MB/s of frames), host a sent " << mbit_s << " Mbit/s; bridge -> host b p50 "
            << percentile(hop_ms, 50) << " ms, p99 " << percentile(hop_ms, 99) << " ms\n";
  RecordProperty("frames_per_s", std::to_string(received / seconds));
  RecordProperty("hop_p50_ms", std::to_string(percentile(hop_ms, 50)));
  EXPECT_GE(received, 4u) << bridge->log();
  EXPECT_TRUE(ordered) << "frames out of capture order";
  bridge->signal(SIGTERM);
  EXPECT_EQ(bridge->wait(30s), 0) << bridge->log();
  std::filesystem::remove_all(dir);
}

}  // namespace
