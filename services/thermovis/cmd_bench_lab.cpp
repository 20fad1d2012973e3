// thermovis bench lab: the pipeline split over three hosts of a lab on this machine (network
// namespaces linked through a switch, deploy/lab/lab.sh; needs root): the bridge and
// rectify-fuse on host a, detect, match and range on host b (reading the frames' packed twins,
// or the plain types with --frames plain), and this command's reader of thermovis/ranges on
// host c. After a warm-up it measures, for --seconds: the captures the bridge made, the results
// that reached host c (per second and as a share of the captures), capture -> host c latency
// and what host a sent on its link (optionally limited to --link-rate by tc).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "command.hpp"
#include "thermovis/metrics/percentile.hpp"
#include "thermovis/perception.h"
#include "thermovis/process/lab.hpp"
#include "thermovis/process/process_group.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

namespace tv = thermovis;
using Clock = std::chrono::steady_clock;

struct Options {
  double rate_hz = 25.0;
  double seconds = 20.0;
  double warmup_s = 10.0;
  std::string frames = "packed";  // host b's --frame-transport
  std::string link_rate;          // tc rate of host a's link, e.g. 1gbit; empty: none
  std::string profile = tv::transport::kUdpProfile;
  std::string scene;  // empty: the paper scene
  int mtu = 0;        // 0: lab.sh's default (1500)
  int prerender = 10;
  double grid_scale = 0.5;  // rectify-fuse --grid-scale
  int domain = -1;          // -1: one of this process's own
  std::string log_dir = "/tmp/thermovis-lab-logs";
  bool json = false;
};

// The services of the split, each on its host, in start order.
tv::process::Manifest split_manifest(const tv::process::Lab& lab, const Options& opt,
                                     const std::filesystem::path& bin,
                                     const std::filesystem::path& scene, int domain) {
  tv::process::Manifest m;
  m.name = "lab";
  const auto add = [&](const std::string& name, const std::string& host,
                       std::vector<std::string> extra, std::vector<std::string> depends) {
    std::vector<std::string> argv{(bin / ("thermovis-" + name)).string(), "--domain",
                                  std::to_string(domain), "--profile", opt.profile};
    if (host == "b") argv.insert(argv.end(), {"--frame-transport", opt.frames});
    argv.insert(argv.end(), extra.begin(), extra.end());
    tv::process::ServiceSpec s;
    s.name = name;
    s.command = lab.on(host, argv);
    s.depends_on = std::move(depends);
    m.services.push_back(std::move(s));
  };
  add("bridge", "a",
      {"--source", "sim", "--scene", scene.string(), "--prerender", std::to_string(opt.prerender),
       "--rate", std::to_string(opt.rate_hz)},
      {});
  add("rectify-fuse", "a", {"--grid-scale", std::to_string(opt.grid_scale)}, {"bridge"});
  add("detect", "b", {}, {"rectify-fuse"});
  add("match", "b", {}, {"detect"});
  add("range", "b", {}, {"match"});
  return m;
}

// Results received at host c.
struct Received {
  std::vector<double> latency_ms;  // capture -> host c
  std::set<std::uint64_t> seqs;
  std::uint64_t first_seq = std::numeric_limits<std::uint64_t>::max(), last_seq = 0;
  std::int64_t first_capture_ns = 0, last_capture_ns = 0;

  void add(const tv::RangeArray& a, std::int64_t received_ns) {
    latency_ms.push_back(static_cast<double>(received_ns - a.capture_time_ns()) / 1e6);
    seqs.insert(a.frame_seq());
    if (a.frame_seq() < first_seq) {
      first_seq = a.frame_seq();
      first_capture_ns = a.capture_time_ns();
    }
    if (a.frame_seq() >= last_seq) {
      last_seq = a.frame_seq();
      last_capture_ns = a.capture_time_ns();
    }
  }
  std::uint64_t captures() const { return seqs.empty() ? 0 : last_seq - first_seq + 1; }
  double bridge_rate_hz() const {
    const double span_s = static_cast<double>(last_capture_ns - first_capture_ns) / 1e9;
    return span_s > 0 ? static_cast<double>(last_seq - first_seq) / span_s : 0.0;
  }
};

// Takes ranges until `until`, keeping the supervisor's children going; into `into` when given.
void collect(tv::transport::Reader<tv::RangeArray>& reader, tv::process::ProcessGroup& group,
             Clock::time_point until, Received* into) {
  while (Clock::now() < until) {
    reader.wait_for_data(std::chrono::milliseconds(50));
    auto samples = reader.take();
    const std::int64_t now = tv::transport::now_ns();
    for (std::size_t i = 0; i < samples.size() && into != nullptr; ++i) into->add(samples[i], now);
    group.poll();
  }
}

int run_bench(const Options& opt) {
  std::string why;
  const auto lab = tv::process::Lab::make({"a", "b", "c"}, true, opt.mtu, why);
  if (!lab) throw std::runtime_error(why);
  if (!opt.link_rate.empty()) lab->shape("a", {"--rate", opt.link_rate});
  const int domain = opt.domain >= 0 ? opt.domain : 100 + ::getpid() % 100;
  const auto bin = std::filesystem::canonical("/proc/self/exe").parent_path();
  const auto scene = opt.scene.empty() ? tv::runtime::shipped_scene_path("paper")
                                       : std::filesystem::path(opt.scene);

  // This command's participant on host c (its sockets are opened in c's namespace).
  std::unique_ptr<tv::transport::Participant> participant;
  std::unique_ptr<tv::transport::Reader<tv::RangeArray>> ranges;
  {
    const tv::process::NetnsScope on_c(lab->ns("c"));
    tv::transport::ParticipantConfig pc;
    pc.domain_id = domain;
    pc.profile = opt.profile;
    pc.profiles_file = tv::transport::shipped_profile_file(opt.profile);
    pc.name = "bench-lab-consumer";
    participant = std::make_unique<tv::transport::Participant>(pc);
    ranges = std::make_unique<tv::transport::Reader<tv::RangeArray>>(
        *participant, tv::transport::topics::kRanges, tv::transport::event_topic_qos(64));
  }
  tv::process::ProcessGroupOptions go;
  go.log_dir = opt.log_dir;
  tv::process::ProcessGroup group(split_manifest(*lab, opt, bin, scene, domain), go);
  if (!opt.json) {
    std::cerr << "bench lab: hosts a (bridge " << opt.rate_hz << " Hz, rectify-fuse), b (detect, "
              << "match, range; " << opt.frames << " frames), c (this reader); DDS domain "
              << domain << ", logs in " << opt.log_dir << std::endl;
  }
  group.start_all();
  const auto t0 = Clock::now();
  // The first result (services start, discover each other over the lab, make their maps).
  Received first;
  while (first.seqs.empty() && Clock::now() < t0 + std::chrono::seconds(120))
    collect(*ranges, group, Clock::now() + std::chrono::milliseconds(200), &first);
  if (first.seqs.empty()) {
    throw std::runtime_error("no ranges reached host c within 120 s (service logs in " +
                             opt.log_dir + ")");
  }
  collect(*ranges, group,
          Clock::now() + std::chrono::milliseconds(static_cast<int>(opt.warmup_s * 1000)), nullptr);
  const std::uint64_t tx0 = lab->tx_bytes("a");
  const auto m0 = Clock::now();
  Received got;
  collect(*ranges, group, m0 + std::chrono::milliseconds(static_cast<int>(opt.seconds * 1000)),
          &got);
  const double window_s = std::chrono::duration<double>(Clock::now() - m0).count();
  const double link_mbit_s = static_cast<double>(lab->tx_bytes("a") - tx0) * 8.0 / 1e6 / window_s;
  std::map<std::string, int> restarts;
  for (const auto& s : group.status()) restarts[s.name] = s.restarts;
  group.stop_all();

  const double results_per_s = static_cast<double>(got.seqs.size()) / window_s;
  const double share =
      got.captures() > 0 ? static_cast<double>(got.seqs.size()) / got.captures() : 0.0;
  const double p50 = tv::metrics::percentile(got.latency_ms, 50);
  const double p99 = tv::metrics::percentile(got.latency_ms, 99);
  if (opt.json) {
    nlohmann::json j{{"rate_hz", opt.rate_hz},
                     {"grid_scale", opt.grid_scale},
                     {"frames", opt.frames},
                     {"profile", opt.profile},
                     {"link_rate", opt.link_rate},
                     {"seconds", window_s},
                     {"bridge_rate_hz", got.bridge_rate_hz()},
                     {"captures", got.captures()},
                     {"results", got.seqs.size()},
                     {"results_per_s", results_per_s},
                     {"results_of_captures", share},
                     {"p50_ms", p50},
                     {"p99_ms", p99},
                     {"link_mbit_s", link_mbit_s},
                     {"restarts", restarts}};
    std::cout << j.dump() << std::endl;
    return 0;
  }
  std::cout << std::fixed << std::setprecision(1) << "bridge " << got.bridge_rate_hz()
            << " captures/s; results at host c " << got.seqs.size() << " of " << got.captures()
            << " captures (" << 100.0 * share << " %), " << results_per_s << " /s\n"
            << "capture -> host c p50 " << p50 << " ms, p99 " << p99 << " ms\n"
            << "host a sent " << link_mbit_s << " Mbit/s"
            << (opt.link_rate.empty() ? "" : " (link limited to " + opt.link_rate + ")") << "\n";
  for (const auto& [name, n] : restarts)
    if (n > 0) std::cout << name << " restarted " << n << " times\n";
  return 0;
}

const bool registered = thermovis::cli::register_command(
    {"bench lab",
     "the pipeline split over three hosts of a lab on this machine (network namespaces, root): "
     "results at the consumer host, latency, link load",
     [](CLI::App& app) -> thermovis::cli::Runner {
       auto opt = std::make_shared<Options>();
       app.add_option("--rate", opt->rate_hz, "the bridge's captures per second")
           ->capture_default_str()
           ->check(CLI::Range(0.5, 100.0));
       app.add_option("--seconds", opt->seconds, "measured time")
           ->capture_default_str()
           ->check(CLI::Range(1.0, 3600.0));
       app.add_option("--warmup", opt->warmup_s, "seconds after the first result, not measured")
           ->capture_default_str()
           ->check(CLI::NonNegativeNumber);
       app.add_option("--frames", opt->frames,
                      "how host b reads the frames of host a: packed (the topics' packed "
                      "twins, the pixels only) or plain (the plain types)")
           ->capture_default_str()
           ->check(CLI::IsMember({"packed", "plain"}));
       app.add_option("--link-rate", opt->link_rate,
                      "limit host a's link (tc rate, e.g. 1gbit); default: none");
       app.add_option("--profile", opt->profile,
                      "DDS profile of every participant: thermovis_udp or thermovis_udp_paced")
           ->capture_default_str()
           ->check(CLI::IsMember({tv::transport::kUdpProfile, tv::transport::kUdpPacedProfile}));
       app.add_option("--scene", opt->scene, "simulated scene (default deploy/scenes/paper.yaml)");
       app.add_option("--grid-scale", opt->grid_scale,
                      "rectify-fuse --grid-scale (1.0: the visible cameras' full grid)")
           ->capture_default_str()
           ->check(CLI::Range(0.1, 1.0));
       app.add_option("--mtu", opt->mtu, "the lab links' MTU (0: 1500; jumbo: 9000)")
           ->check(CLI::Range(0, 9000));
       app.add_option("--prerender", opt->prerender, "the bridge's pre-rendered captures")
           ->capture_default_str()
           ->check(CLI::Range(1, 1000));
       app.add_option("--domain", opt->domain, "DDS domain (default: one of this process's)")
           ->check(CLI::Range(0, 232));
       app.add_option("--log-dir", opt->log_dir, "folder of the services' logs")
           ->capture_default_str();
       app.add_flag("--json", opt->json, "one JSON object");
       return [opt] { return run_bench(*opt); };
     }});

}  // namespace
