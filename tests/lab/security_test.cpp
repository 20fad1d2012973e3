// DDS Security (deploy/dds/secure.xml, material from deploy/security/make-security.sh) on one
// host of a lab (its own network namespace, so the test's UDP traffic stays in it):
// - the pipeline runs with every service authenticated and access-controlled; a participant
//   without a certificate neither receives ranges nor gets its detections read; an identity
//   allowed to publish ranges only cannot publish frames;
// - every start of the secured pipeline with all its services at once ranges, with no retry
//   (THERMOVIS_SECURITY_STARTS starts, default 5; 20 for a measurement);
// - a participant with an expired or revoked certificate, a certificate of another CA, or a
//   permissions document signed by another CA or edited after signing neither receives ranges
//   nor gets its ranges read (one that cannot start with its material is not created).
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
#include <thread>
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

// Material a participant is refused with, in folders under `dir`/refused (each a
// THERMOVIS_SECURITY_DIR for the identities thermovis-consumer and thermovis-ranges-only):
//   other-ca          certificates of another CA (identity_ca.cert.pem: that CA), the genuine
//                     permissions
//   forged-permissions  genuine certificates, governance and permissions signed by another CA
//                     (permissions_ca.cert.pem: that CA)
//   revoked           certificates of the genuine CA, then revoked in `security`/crl.pem; the
//                     folder has no revocation list
//   revoked-known     the same with the revocation list
//   expired           certificates of the genuine CA valid in January 2020
//   expiring          certificates of the genuine CA that expire 6 s (thermovis-ranges-only)
//                     and 12 s (thermovis-consumer) after the script; `expiring/ends` says when
//                     (name, seconds since the epoch)
//   edited            genuine certificates, permissions edited after signing
const char* const kRefusedMaterialScript = R"sh(set -euo pipefail
g="$1" out="$2" make_security="$3"
names=(thermovis-consumer thermovis-ranges-only)
mkdir -p "$out" && cd "$out"
mkdir other-ca forged-permissions revoked revoked-known expired expiring edited
openssl ecparam -name prime256v1 -genkey -noout -out forger.key.pem
openssl req -x509 -new -key forger.key.pem -sha256 -days 30 -subj "/O=thermovis/CN=thermovis CA" \
  -out forger.cert.pem
cat >expired.cnf <<EOT
[ ca ]
default_ca = expired
[ expired ]
database = expired.txt
new_certs_dir = .
serial = expired.srl
default_md = sha256
policy = any
preserve = yes
unique_subject = no
[ any ]
organizationName = supplied
commonName = supplied
EOT
: >expired.txt
echo 1000 >expired.srl
issue() {  # FOLDER NAME CA-CERT CA-KEY [START END (openssl ca dates)]
  openssl ecparam -name prime256v1 -genkey -noout -out "$1/$2.key.pem"
  openssl req -new -key "$1/$2.key.pem" -sha256 -subj "/O=thermovis/CN=$2" -out "$1/$2.csr.pem"
  if (($# > 4)); then
    openssl ca -batch -config expired.cnf -cert "$3" -keyfile "$4" -in "$1/$2.csr.pem" -notext \
      -startdate "$5" -enddate "$6" -out "$1/$2.cert.pem" 2>/dev/null
  else
    openssl x509 -req -in "$1/$2.csr.pem" -CA "$3" -CAkey "$4" -CAcreateserial -sha256 -days 30 \
      -out "$1/$2.cert.pem" 2>/dev/null
  fi
  rm "$1/$2.csr.pem"
}
sign() {  # XML SIGNED CA-CERT CA-KEY
  openssl smime -sign -text -in "$1" -out "$2" -signer "$3" -inkey "$4"
}
for n in "${names[@]}"; do
  for f in other-ca revoked expired expiring; do cp "$g/$n.permissions.p7s" "$f/"; done
  issue other-ca "$n" forger.cert.pem forger.key.pem
  issue revoked "$n" "$g/ca.cert.pem" "$g/ca.key.pem"
  issue expired "$n" "$g/ca.cert.pem" "$g/ca.key.pem" 20200101000000Z 20200131000000Z
  for f in forged-permissions edited; do cp "$g/$n.cert.pem" "$g/$n.key.pem" "$f/"; done
  sign "$g/$n.permissions.xml" "forged-permissions/$n.permissions.p7s" forger.cert.pem forger.key.pem
  sed 's#<topic>thermovis/ranges</topic>#<topic>thermovis/*</topic>#' "$g/$n.permissions.p7s" \
    >"edited/$n.permissions.p7s"
  cmp -s "$g/$n.permissions.p7s" "edited/$n.permissions.p7s" && { echo "nothing edited" >&2; exit 1; }
done
for f in other-ca forged-permissions revoked expired expiring edited; do cp "$g/ca.cert.pem" "$f/"; done
for f in other-ca revoked expired expiring edited; do cp "$g/governance.p7s" "$f/"; done
cp forger.cert.pem other-ca/identity_ca.cert.pem
cp forger.cert.pem forged-permissions/permissions_ca.cert.pem
sign "$g/governance.xml" forged-permissions/governance.p7s forger.cert.pem forger.key.pem
bash "$make_security" --out "$g" --revoke revoked/thermovis-consumer.cert.pem \
  --revoke revoked/thermovis-ranges-only.cert.pem
cp -r revoked/. revoked-known/
cp "$g/crl.pem" revoked-known/
now=$(date -u +%s)
stamp() { date -u -d "@$1" +%Y%m%d%H%M%SZ; }
for pair in thermovis-ranges-only:6 thermovis-consumer:12; do
  n="${pair%%:*}" end=$((now + ${pair##*:}))
  issue expiring "$n" "$g/ca.cert.pem" "$g/ca.key.pem" "$(stamp $((now - 60)))" "$(stamp "$end")"
  echo "$n $end" >>expiring/ends
done
)sh";

// A participant with `folder`'s material for `name`, or null when it cannot be made.
std::unique_ptr<tv::transport::Participant> participant_with(const std::filesystem::path& folder,
                                                             int domain, const std::string& name,
                                                             std::string& error) {
  const char* before = std::getenv("THERMOVIS_SECURITY_DIR");
  const std::string restore = before != nullptr ? before : "";
  ::setenv("THERMOVIS_SECURITY_DIR", folder.c_str(), 1);
  std::unique_ptr<tv::transport::Participant> p;
  try {
    p = participant(domain, tv::transport::kSecureProfile, name);
  } catch (const std::exception& e) {
    error = e.what();
  }
  ::setenv("THERMOVIS_SECURITY_DIR", restore.c_str(), 1);
  return p;
}

TEST(Security, RefusedMaterialNeitherReadsNorIsRead) {
  std::string why;
  const auto lab = thermovis::test::Lab::make({"a"}, true, why);
  if (!lab) GTEST_SKIP() << why;
  const auto dir = thermovis::test::temp_dir("lab-security-refused");
  const auto security = make_material(dir);
  ChildProcess refused_script(
      {"/bin/bash", "-c", kRefusedMaterialScript, "refused-material", security.string(),
       (dir / "refused").string(),
       (thermovis::test::source_root() / "deploy/security/make-security.sh").string()},
      dir / "refused-material.log");
  ASSERT_EQ(refused_script.wait(120s), 0) << refused_script.log();
  const auto refused = dir / "refused";
  ::setenv("THERMOVIS_SECURITY_DIR", security.c_str(), 1);
  const int domain = thermovis::test::private_domain();
  const thermovis::test::NetnsScope on_a(lab->ns("a"));

  // Certificates that expire while their participants run, before any genuine participant is
  // there to meet them: thermovis-ranges-only's first, then thermovis-consumer's, which starts
  // once the other's has expired, so that the two do not authenticate each other either.
  std::map<std::string, std::chrono::system_clock::time_point> expires;
  {
    std::ifstream ends(refused / "expiring/ends");
    std::string name;
    for (long long at = 0; ends >> name >> at;)
      expires[name] = std::chrono::system_clock::time_point(std::chrono::seconds(at));
  }
  ASSERT_EQ(expires.size(), 2u);
  std::string expiring_error;
  const auto expiring_writing =
      participant_with(refused / "expiring", domain, "thermovis-ranges-only", expiring_error);
  ASSERT_TRUE(expiring_writing) << expiring_error;
  tv::transport::Writer<tv::RangeArray> expiring_writer(
      *expiring_writing, tv::transport::topics::kRanges, tv::transport::event_topic_qos());
  std::this_thread::sleep_until(expires["thermovis-ranges-only"] + 1s);
  const auto expiring_reading =
      participant_with(refused / "expiring", domain, "thermovis-consumer", expiring_error);
  ASSERT_TRUE(expiring_reading) << expiring_error;
  tv::transport::Reader<tv::RangeArray> expiring_reader(
      *expiring_reading, tv::transport::topics::kRanges, tv::transport::event_topic_qos(64));
  std::this_thread::sleep_until(expires["thermovis-consumer"] + 1s);

  // The secured pipeline (which reads crl.pem) and its genuine consumer.
  const auto consumer = participant(domain, tv::transport::kSecureProfile, "thermovis-consumer");
  tv::transport::Reader<tv::RangeArray> ranges(*consumer, tv::transport::topics::kRanges,
                                               tv::transport::event_topic_qos(64));
  LabPipeline secured(
      *lab, "a", domain, tv::transport::kSecureProfile, dir,
      std::map<std::string, std::string>{{"THERMOVIS_SECURITY_DIR", security.string()}});
  ASSERT_GE(range_hops(ranges, 3, 60s).size(), 3u) << secured.logs();

  // Material that its own participant already refuses (Fast DDS checks its certificate
  // against the CA and the revocation list, and the signature of its documents, when it starts).
  for (const std::string folder : {"expired", "revoked-known", "edited"}) {
    for (const std::string name : {"thermovis-consumer", "thermovis-ranges-only"}) {
      std::string error;
      EXPECT_EQ(participant_with(refused / folder, domain, name, error), nullptr)
          << folder << "/" << name << " made a participant";
      EXPECT_NE(error.find("cannot create DDS participant"), std::string::npos) << error;
    }
  }

  // Material that starts but that the genuine participants refuse: readers of ranges under the
  // consumer's name, then writers of ranges under the name that may publish them (an intruder
  // may match another with the same forged trust, so one kind at a time). "genuine" is the
  // control: the same participant with the genuine material.
  const std::vector<std::string> folders{"other-ca", "forged-permissions", "revoked", "genuine"};
  for (const bool reading : {true, false}) {
    const std::string name = reading ? "thermovis-consumer" : "thermovis-ranges-only";
    std::vector<std::unique_ptr<tv::transport::Participant>> participants;
    std::vector<std::unique_ptr<tv::transport::Reader<tv::RangeArray>>> readers;
    std::vector<std::unique_ptr<tv::transport::Writer<tv::RangeArray>>> writers;
    for (const auto& folder : folders) {
      std::string error;
      participants.push_back(
          participant_with(folder == "genuine" ? security : refused / folder, domain, name, error));
      ASSERT_TRUE(participants.back()) << folder << "/" << name << ": " << error;
      if (reading) {
        readers.push_back(std::make_unique<tv::transport::Reader<tv::RangeArray>>(
            *participants.back(), tv::transport::topics::kRanges,
            tv::transport::event_topic_qos(64)));
      } else {
        writers.push_back(std::make_unique<tv::transport::Writer<tv::RangeArray>>(
            *participants.back(), tv::transport::topics::kRanges,
            tv::transport::event_topic_qos()));
      }
    }
    // The control matches within seconds (a genuine start ranges within 3 s); then as long
    // again for the others, while the pipeline keeps ranging to its consumer.
    const auto begin = Clock::now();
    const bool control = reading ? readers.back()->wait_for_writers(1, 30s)
                                 : writers.back()->wait_for_readers(1, 30s);
    EXPECT_TRUE(control) << "the genuine " << name << " matched nobody";
    ranges.take();
    const auto delivered = range_hops(
        ranges, 1000, std::chrono::duration_cast<std::chrono::seconds>(Clock::now() - begin) + 3s);
    EXPECT_GE(delivered.size(), 20u) << "the pipeline stopped ranging to its consumer";
    for (std::size_t i = 0; i + 1 < folders.size(); ++i) {
      if (reading) {
        EXPECT_EQ(readers[i]->take().size(), 0u) << folders[i] << ": ranges read";
        EXPECT_FALSE(readers[i]->wait_for_writers(1, 100ms)) << folders[i] << ": matched a writer";
      } else {
        EXPECT_FALSE(writers[i]->wait_for_readers(1, 100ms)) << folders[i] << ": ranges read";
      }
    }
    if (reading) {
      EXPECT_GT(readers.back()->take().size(), 0u) << "the genuine consumer read nothing";
    }
  }
  // The participants whose certificates expired meanwhile.
  EXPECT_EQ(expiring_reader.take().size(), 0u) << "expiring: ranges read";
  EXPECT_FALSE(expiring_reader.wait_for_writers(1, 100ms)) << "expiring: matched a writer";
  EXPECT_FALSE(expiring_writer.wait_for_readers(1, 100ms)) << "expiring: ranges read";
  secured.stop();
  ::unsetenv("THERMOVIS_SECURITY_DIR");
  std::filesystem::remove_all(dir);
}

}  // namespace
