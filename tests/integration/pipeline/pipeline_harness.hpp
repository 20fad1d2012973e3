#pragma once
// What the pipeline's multi-process tests share: this test's own DDS participant (loopback
// profile), a service's and the supervisor's command lines on a private domain, and the
// supervisor's summary.
#include <sys/types.h>
#include <chrono>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "thermovis/test/data.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::test {

inline std::unique_ptr<transport::Participant> loopback_participant(int domain,
                                                                    const std::string& name) {
  transport::ParticipantConfig pc;
  pc.domain_id = domain;
  pc.profile = transport::kLoopbackProfile;
  pc.profiles_file = transport::shipped_profile_file(pc.profile);
  pc.name = name;
  return std::make_unique<transport::Participant>(pc);
}

// The built `executable` ("thermovis-range") on `domain` (loopback profile), with `extra`
// arguments.
inline std::vector<std::string> service_command(const std::string& executable, int domain,
                                                const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv{(bin_dir() / executable).string(), "--domain",
                                std::to_string(domain), "--profile", transport::kLoopbackProfile};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

// thermovis-supervisor on `domain` (loopback profile, logs under dir/logs, JSON summary), with
// `extra` arguments.
inline std::vector<std::string> supervisor_command(const std::filesystem::path& dir, int domain,
                                                   const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv = service_command("thermovis-supervisor", domain,
                                                  {"--log-dir", (dir / "logs").string(), "--json"});
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

// `thermovis record` on `domain` (loopback profile, JSON summary), with `args` (what to record
// and for how long).
inline std::vector<std::string> record_command(int domain, const std::vector<std::string>& args) {
  std::vector<std::string> argv{(bin_dir() / "thermovis").string(), "record"};
  argv.insert(argv.end(), args.begin(), args.end());
  argv.insert(argv.end(), {"--domain", std::to_string(domain), "--profile",
                           transport::kLoopbackProfile, "--json"});
  return argv;
}

// The services' logs the supervisor of supervisor_command(dir, ...) wrote, each headed by its
// name: what a failed pipeline test prints.
inline std::string service_logs(const std::filesystem::path& dir) {
  std::string all;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir / "logs", ec)) {
    std::ifstream in(entry.path());
    std::stringstream text;
    text << in.rdbuf();
    all += "---- " + entry.path().filename().string() + "\n" + text.str();
  }
  return all;
}

// The last line of a log that is a JSON object (the supervisor's --json summary); null if none.
inline nlohmann::json last_json_line(const std::string& log) {
  std::istringstream lines(log);
  std::string last;
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line.front() == '{') last = line;
  }
  return last.empty() ? nlohmann::json() : nlohmann::json::parse(last);
}

// Waits for samples of `reader`, handing each batch taken to `done` (which copies what it needs:
// frame types are megabytes, not for the stack) until it returns true; false on timeout.
template <class T, class Done>
bool receive_batches(transport::Reader<T>& reader, Done&& done, std::chrono::milliseconds timeout) {
  const auto until = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < until) {
    reader.wait_for_data(std::chrono::milliseconds(100));
    const auto samples = reader.take();
    if (done(samples)) return true;
  }
  return false;
}

// Waits for the first sample of `reader` satisfying `ok` (which copies what it needs); false on
// timeout.
template <class T>
bool receive(transport::Reader<T>& reader, const std::function<bool(const T&)>& ok,
             std::chrono::seconds timeout) {
  return receive_batches(
      reader,
      [&](const transport::Samples<T>& samples) {
        for (std::size_t i = 0; i < samples.size(); ++i)
          if (ok(samples[i])) return true;
        return false;
      },
      timeout);
}

// The health the services publish on a participant's domain, the last sample of each kept.
class HealthWatch {
 public:
  explicit HealthWatch(transport::Participant& participant)
      : reader_(participant, transport::topics::kHealth, transport::state_topic_qos()) {}

  // Takes the samples that arrive until the last health of `service` ("thermovis-range")
  // satisfies `ok`: that health, or nothing once `timeout` has passed.
  std::optional<Health> wait(const std::string& service,
                             const std::function<bool(const Health&)>& ok,
                             std::chrono::milliseconds timeout) {
    const bool seen = receive_batches(
        reader_,
        [&](const transport::Samples<Health>& samples) {
          for (std::size_t i = 0; i < samples.size(); ++i)
            last_[samples[i].service().to_string()] = samples[i];
          const auto health = last(service);
          return health && ok(*health);
        },
        timeout);
    return seen ? last(service) : std::nullopt;
  }

  // The last health of `service` taken so far, if any.
  std::optional<Health> last(const std::string& service) const {
    const auto it = last_.find(service);
    return it == last_.end() ? std::nullopt : std::optional<Health>(it->second);
  }

 private:
  transport::Reader<Health> reader_;
  std::map<std::string, Health> last_;
};

inline Box2D box2d(float x, float y, float width, float height) {
  Box2D box;
  box.x(x);
  box.y(y);
  box.width(width);
  box.height(height);
  return box;
}

// The pid of service `name` ("bridge") running on DDS domain `domain`, or 0.
inline pid_t service_pid(const std::string& name, int domain) {
  const std::string path = (bin_dir() / ("thermovis-" + name)).string();
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string pid = entry.path().filename().string();
    if (pid.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream in(entry.path() / "cmdline");
    std::vector<std::string> argv;
    for (std::string arg; std::getline(in, arg, '\0');) argv.push_back(arg);
    if (argv.size() < 3 || argv[0] != path) continue;
    for (std::size_t i = 1; i + 1 < argv.size(); ++i) {
      if (argv[i] == "--domain" && argv[i + 1] == std::to_string(domain))
        return static_cast<pid_t>(std::stoi(pid));
    }
  }
  return 0;
}

}  // namespace thermovis::test
