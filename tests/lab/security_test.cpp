// DDS Security (deploy/dds/secure.xml, material from deploy/security/make-security.sh) on one
// host of a lab (its own network namespace, so the test's UDP traffic stays in it): the pipeline
// runs with every service authenticated and access-controlled; a participant without a
// certificate neither receives ranges nor gets its detections read; an identity allowed to
// publish ranges only cannot publish frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "lab_harness.hpp"
#include "thermovis/frames.h"
#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using thermovis::test::ChildProcess;
namespace tv = thermovis;

std::unique_ptr<tv::transport::Participant> participant(int domain, const std::string& profile,
                                                        const std::string& name) {
  tv::transport::ParticipantConfig pc;
  pc.domain_id = domain;
  pc.profile = profile;
  pc.profiles_file = tv::transport::shipped_profile_file(profile);
  pc.name = name;
  return std::make_unique<tv::transport::Participant>(pc);
}

TEST(Security, PipelineRunsAuthenticatedAndStrangersNeitherReadNorInject) {
  std::string why;
  const auto lab = thermovis::test::Lab::make({"a"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  const auto dir = thermovis::test::temp_dir("lab-security");
  ChildProcess make(
      {"/bin/bash", (thermovis::test::source_root() / "deploy/security/make-security.sh").string(),
       "--out", (dir / "security").string()},
      dir / "make-security.log");
  ASSERT_EQ(make.wait(120s), 0) << make.log();
  ::setenv("THERMOVIS_SECURITY_DIR", (dir / "security").c_str(), 1);
  const int domain = thermovis::test::private_domain();
  const thermovis::test::NetnsScope on_a(lab->ns("a"));

  const auto bin = thermovis::test::bin_dir();
  const auto scene = thermovis::test::source_root() / "deploy/scenes/paper.yaml";
  std::vector<std::pair<std::string, std::unique_ptr<ChildProcess>>> services;
  for (const auto& [service, extra] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"thermovis-bridge",
            {"--source", "sim", "--scene", scene.string(), "--prerender", "10", "--rate", "10"}},
           {"thermovis-rectify-fuse", {}},
           {"thermovis-detect", {}},
           {"thermovis-match", {}},
           {"thermovis-range", {}}}) {
    std::vector<std::string> argv{(bin / service).string(), "--domain", std::to_string(domain),
                                  "--profile", tv::transport::kSecureProfile};
    argv.insert(argv.end(), extra.begin(), extra.end());
    services.emplace_back(service, lab->start("a", argv, dir / (service + ".log"),
                                              {{"THERMOVIS_SECURITY_DIR", (dir / "security")}}));
  }
  auto logs = [&] {
    std::string all;
    for (const auto& [name, p] : services) all += "---- " + name + "\n" + p->log();
    return all;
  };

  // An authenticated consumer, and a stranger with no certificate on the same domain.
  const auto consumer = participant(domain, tv::transport::kSecureProfile, "thermovis-consumer");
  tv::transport::Reader<tv::RangeArray> ranges(*consumer, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  const auto stranger = participant(domain, tv::transport::kUdpProfile, "stranger");
  tv::transport::Reader<tv::RangeArray> stolen(*stranger, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  tv::transport::Writer<tv::DetectionArray> injected(*stranger, tv::transport::topics::kDetections,
                                                     tv::transport::event_topic_qos());

  int with_targets = 0;
  std::vector<double> last_hop_ms;
  const auto until = Clock::now() + 150s;
  while (Clock::now() < until && with_targets < 10) {
    ranges.wait_for_data(100ms);
    auto samples = ranges.take();
    const std::int64_t now = tv::transport::now_ns();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (samples[i].targets().empty()) continue;
      ++with_targets;
      const auto& stamps = samples[i].stamps().stamps();
      for (std::size_t k = stamps.size(); k-- > 0;) {
        if (stamps[k].stage() == tv::STAGE_RANGE) {
          last_hop_ms.push_back((now - stamps[k].end_ns()) / 1e6);
          break;
        }
      }
    }
  }
  ASSERT_GE(with_targets, 10) << "the secured pipeline gave no ranges\n" << logs();
  std::sort(last_hop_ms.begin(), last_hop_ms.end());
  std::cout << "secured: range -> consumer p50 " << last_hop_ms[last_hop_ms.size() / 2]
            << " ms (encrypted small topic)\n";
  RecordProperty("range_to_consumer_p50_ms", std::to_string(last_hop_ms[last_hop_ms.size() / 2]));

  // The stranger matched nobody: nothing read, nothing of its detections delivered.
  EXPECT_EQ(stolen.take().size(), 0u);
  EXPECT_FALSE(stolen.wait_for_writers(1, 100ms));
  EXPECT_FALSE(injected.wait_for_readers(1, 100ms));

  // Permissions: an identity that may publish ranges only.
  const auto limited = participant(domain, tv::transport::kSecureProfile, "thermovis-ranges-only");
  EXPECT_NO_THROW(tv::transport::Writer<tv::RangeArray>(*limited, tv::transport::topics::kRanges,
                                                        tv::transport::event_topic_qos()));
  EXPECT_THROW(
      tv::transport::Writer<tv::VisibleStereoFrame>(*limited, tv::transport::topics::kVisibleFrames,
                                                    tv::transport::frame_topic_qos()),
      std::runtime_error);

  for (auto it = services.rbegin(); it != services.rend(); ++it) {
    it->second->signal(SIGTERM);
    EXPECT_EQ(it->second->wait(30s), 0) << it->first << "\n" << it->second->log();
  }
  ::unsetenv("THERMOVIS_SECURITY_DIR");
  std::filesystem::remove_all(dir);
}

}  // namespace
