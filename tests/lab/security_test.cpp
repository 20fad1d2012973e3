// DDS Security (deploy/dds/secure.xml, material from deploy/security/make-security.sh) on one
// host of a lab (its own network namespace, so the test's UDP traffic stays in it):
// - the pipeline runs with every service authenticated and access-controlled; a participant
//   without a certificate neither receives ranges nor gets its detections read; an identity
//   allowed to publish ranges only cannot publish frames;
// - every start of the secured pipeline with all its services at once ranges, with no retry
//   (THERMOVIS_SECURITY_STARTS starts, default 5; 20 for a measurement).
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
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

// A participant of `profile` in `file` (default: the shipped file of that profile).
std::unique_ptr<tv::transport::Participant> participant(int domain, const std::string& profile,
                                                        const std::string& name,
                                                        const std::filesystem::path& file = {}) {
  tv::transport::ParticipantConfig pc;
  pc.domain_id = domain;
  pc.profile = profile;
  pc.profiles_file = file.empty() ? tv::transport::shipped_profile_file(profile) : file;
  pc.name = name;
  return std::make_unique<tv::transport::Participant>(pc);
}

// Data-sharing pools of other processes' writers that process `pid` maps (read-only shared
// mappings of /dev/shm/fast_datasharing_*): how a reader on this host gets frames without a copy.
int data_sharing_pools_read(pid_t pid) {
  std::ifstream maps("/proc/" + std::to_string(pid) + "/maps");
  std::set<std::string> pools;
  for (std::string line; std::getline(maps, line);) {
    std::istringstream fields(line);
    std::string range, perms, offset, device, inode, path;
    fields >> range >> perms >> offset >> device >> inode >> path;
    if (perms.rfind("r--s", 0) == 0 && path.find("/fast_datasharing_") != std::string::npos)
      pools.insert(path);
  }
  return static_cast<int>(pools.size());
}

// The five services on lab host `host` with one participant profile.
class LabPipeline {
 public:
  LabPipeline(const thermovis::test::Lab& lab, const std::string& host, int domain,
              const std::string& profile, const std::filesystem::path& dir,
              const std::map<std::string, std::string>& env) {
    const auto bin = thermovis::test::bin_dir();
    const auto scene = thermovis::test::source_root() / "deploy/scenes/paper.yaml";
    for (const auto& [service, extra] :
         std::vector<std::pair<std::string, std::vector<std::string>>>{
             {"thermovis-bridge",
              {"--source", "sim", "--scene", scene.string(), "--prerender", "10", "--rate", "10"}},
             {"thermovis-rectify-fuse", {}},
             {"thermovis-detect", {}},
             {"thermovis-match", {}},
             {"thermovis-range", {}}}) {
      std::vector<std::string> argv{(bin / service).string(), "--domain", std::to_string(domain),
                                    "--profile", profile};
      argv.insert(argv.end(), extra.begin(), extra.end());
      services_.emplace_back(service,
                             lab.start(host, argv, dir / (service + "." + profile + ".log"), env));
    }
  }

  pid_t pid(const std::string& service) const {
    for (const auto& [name, p] : services_)
      if (name == service) return p->pid();
    return -1;
  }
  // The services' logs (after stop(): as they were when the services had exited).
  std::string logs() const {
    if (services_.empty()) return stopped_logs_;
    std::string all;
    for (const auto& [name, p] : services_) all += "---- " + name + "\n" + p->log();
    return all;
  }
  // SIGTERM, last service first; each must exit 0.
  void stop() {
    for (auto it = services_.rbegin(); it != services_.rend(); ++it) {
      it->second->signal(SIGTERM);
      EXPECT_EQ(it->second->wait(30s), 0) << it->first << "\n" << it->second->log();
    }
    stopped_logs_ = logs();
    services_.clear();
  }

 private:
  std::vector<std::pair<std::string, std::unique_ptr<ChildProcess>>> services_;
  std::string stopped_logs_;
};

// Waits for `wanted` range arrays with targets; the range -> consumer hop of each, ms (from the
// range stage's end stamp to the arrival here).
std::vector<double> range_hops(tv::transport::Reader<tv::RangeArray>& ranges, int wanted,
                               std::chrono::seconds timeout) {
  std::vector<double> hops;
  const auto until = Clock::now() + timeout;
  while (Clock::now() < until && static_cast<int>(hops.size()) < wanted) {
    ranges.wait_for_data(100ms);
    auto samples = ranges.take();
    const std::int64_t now = tv::transport::now_ns();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      if (samples[i].targets().empty()) continue;
      const auto& stamps = samples[i].stamps().stamps();
      for (std::size_t k = stamps.size(); k-- > 0;) {
        if (stamps[k].stage() == tv::STAGE_RANGE) {
          hops.push_back((now - stamps[k].end_ns()) / 1e6);
          break;
        }
      }
    }
  }
  std::sort(hops.begin(), hops.end());
  return hops;
}

double median(const std::vector<double>& sorted) { return sorted[sorted.size() / 2]; }

// The CA, identities and documents of deploy/security/make-security.sh in `dir`/security.
std::filesystem::path make_material(const std::filesystem::path& dir) {
  ChildProcess make(
      {"/bin/bash", (thermovis::test::source_root() / "deploy/security/make-security.sh").string(),
       "--out", (dir / "security").string()},
      dir / "make-security.log");
  const auto code = make.wait(120s);
  if (code != 0) throw std::runtime_error("make-security.sh failed:\n" + make.log());
  return dir / "security";
}

// A participant profile in a file of its own for a participant without security that finds the
// secured participants as they find each other (unicast to the ports of this host, secure.xml).
// Each call makes a new profile name: Fast DDS keeps every loaded profile for the process.
std::pair<std::filesystem::path, std::string> stranger_profile(const std::filesystem::path& dir) {
  static std::atomic<int> counter{0};
  const std::string name = "thermovis_test_stranger_" + std::to_string(counter++);
  std::string xml = R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>NAME_udp</transport_id>
        <type>UDPv4</type>
        <maxInitialPeersRange>16</maxInitialPeersRange>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="NAME">
      <rtps>
        <userTransports><transport_id>NAME_udp</transport_id></userTransports>
        <useBuiltinTransports>false</useBuiltinTransports>
        <builtin>
          <initialPeersList>
            <locator><udpv4><address>127.0.0.1</address></udpv4></locator>
          </initialPeersList>
        </builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
)";
  for (std::size_t at; (at = xml.find("NAME")) != std::string::npos;) xml.replace(at, 4, name);
  const auto file = dir / (name + ".xml");
  std::ofstream(file) << xml;
  return {file, name};
}

TEST(Security, PipelineRunsAuthenticatedAndStrangersNeitherReadNorInject) {
  std::string why;
  const auto lab = thermovis::test::Lab::make({"a"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  const auto dir = thermovis::test::temp_dir("lab-security");
  const auto security = make_material(dir);
  ::setenv("THERMOVIS_SECURITY_DIR", security.c_str(), 1);
  // The unsecured stage on a domain of its own, so that the secured participants meet only
  // each other, the consumer and the stranger.
  const int plain_domain = thermovis::test::second_private_domain();
  const int domain = thermovis::test::private_domain();
  const thermovis::test::NetnsScope on_a(lab->ns("a"));

  // The same pipeline and consumer first without security (thermovis_host: the same
  // transports, shared memory and UDP), for the cost of security on one host.
  std::vector<double> plain_hops;
  int plain_pools = 0;
  {
    LabPipeline plain(*lab, "a", plain_domain, tv::transport::kHostProfile, dir, {});
    const auto consumer = participant(plain_domain, tv::transport::kHostProfile, "plain-consumer");
    tv::transport::Reader<tv::RangeArray> ranges(*consumer, tv::transport::topics::kRanges,
                                                 tv::transport::event_topic_qos(64));
    plain_hops = range_hops(ranges, 30, 150s);
    ASSERT_GE(plain_hops.size(), 10u) << "the pipeline gave no ranges\n" << plain.logs();
    plain_pools = data_sharing_pools_read(plain.pid("thermovis-rectify-fuse"));
    plain.stop();
  }

  // An authenticated consumer, and a stranger with no certificate on the same domain that
  // announces itself to the secured participants and hears their announcements.
  const auto consumer = participant(domain, tv::transport::kSecureProfile, "thermovis-consumer");
  tv::transport::Reader<tv::RangeArray> ranges(*consumer, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  const auto [stranger_file, stranger_name] = stranger_profile(dir);
  const auto stranger = participant(domain, stranger_name, "stranger", stranger_file);
  tv::transport::Reader<tv::RangeArray> stolen(*stranger, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  tv::transport::Writer<tv::DetectionArray> injected(*stranger, tv::transport::topics::kDetections,
                                                     tv::transport::event_topic_qos());
  // All services at once; no retry (Security.EverySecuredStartRanges).
  LabPipeline secured(
      *lab, "a", domain, tv::transport::kSecureProfile, dir,
      std::map<std::string, std::string>{{"THERMOVIS_SECURITY_DIR", security.string()}});
  const std::vector<double> secured_hops = range_hops(ranges, 30, 60s);
  if (secured_hops.size() < 10u) {
    secured.stop();
    FAIL() << "the secured pipeline gave " << secured_hops.size() << " range arrays in 60 s:\n"
           << secured.logs();
  }
  const int secured_pools = data_sharing_pools_read(secured.pid("thermovis-rectify-fuse"));
  std::cout << "range -> consumer p50 on one host: unsecured " << median(plain_hops)
            << " ms, secured (encrypted) " << median(secured_hops) << " ms (" << plain_hops.size()
            << ", " << secured_hops.size()
            << " arrays); raw-frame pools rectify-fuse reads by data-sharing: unsecured "
            << plain_pools << ", secured " << secured_pools << "\n";
  RecordProperty("range_to_consumer_p50_ms_unsecured", std::to_string(median(plain_hops)));
  RecordProperty("range_to_consumer_p50_ms_secured", std::to_string(median(secured_hops)));
  // Frames are not encrypted (governance): on one host they stay on data-sharing, the bridge's
  // visible and infrared pools mapped by rectify-fuse, secured or not.
  EXPECT_GE(plain_pools, 2);
  EXPECT_EQ(secured_pools, plain_pools);

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

  secured.stop();
  ::unsetenv("THERMOVIS_SECURITY_DIR");
  std::filesystem::remove_all(dir);
}

// How many times Security.EverySecuredStartRanges starts the pipeline.
int secured_starts() {
  const char* env = std::getenv("THERMOVIS_SECURITY_STARTS");
  const int n = env != nullptr ? std::atoi(env) : 0;
  return n > 0 ? n : 5;
}

// The secured pipeline started again and again with all its services at once, an authenticated
// consumer on the domain the whole time: every start must range, with no retry. Fast DDS 2.9.1
// can mix up the handshake endpoints of two peers that one participant discovers at once on
// two receive threads; those two then never match (deploy/dds/secure.xml, which keeps
// discovery on one socket for that).
TEST(Security, EverySecuredStartRanges) {
  std::string why;
  const auto lab = thermovis::test::Lab::make({"a"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  const auto dir = thermovis::test::temp_dir("lab-security-starts");
  const auto security = make_material(dir);
  ::setenv("THERMOVIS_SECURITY_DIR", security.c_str(), 1);
  const int domain = thermovis::test::private_domain();
  const thermovis::test::NetnsScope on_a(lab->ns("a"));
  const auto consumer = participant(domain, tv::transport::kSecureProfile, "thermovis-consumer");
  tv::transport::Reader<tv::RangeArray> ranges(*consumer, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  const int starts = secured_starts();
  std::vector<double> seconds;
  for (int start = 1; start <= starts; ++start) {
    const auto begin = Clock::now();
    LabPipeline secured(
        *lab, "a", domain, tv::transport::kSecureProfile, dir,
        std::map<std::string, std::string>{{"THERMOVIS_SECURITY_DIR", security.string()}});
    const auto hops = range_hops(ranges, 3, 60s);
    const double took = std::chrono::duration<double>(Clock::now() - begin).count();
    const int pools = data_sharing_pools_read(secured.pid("thermovis-rectify-fuse"));
    // Stopped first, so that each service's log ends with its counts (frames processed,
    // dropped, answered): they say which stage never got its input.
    secured.stop();
    if (hops.size() >= 3u) {
      seconds.push_back(took);
    } else {
      ADD_FAILURE() << "start " << start << " of " << starts << ": " << hops.size()
                    << " range arrays in 60 s; rectify-fuse maps " << pools
                    << " data-sharing pools of the bridge; the services' logs:\n"
                    << secured.logs();
    }
    ranges.take();
  }
  std::sort(seconds.begin(), seconds.end());
  std::cout << "secured starts that ranged: " << seconds.size() << " of " << starts;
  if (!seconds.empty()) {
    std::cout << "; start to the third range array p50 " << median(seconds) << " s, max "
              << seconds.back() << " s";
  }
  std::cout << "\n";
  RecordProperty("secured_starts_ranged", std::to_string(seconds.size()));
  RecordProperty("secured_starts", std::to_string(starts));
  ::unsetenv("THERMOVIS_SECURITY_DIR");
  std::filesystem::remove_all(dir);
}

}  // namespace
