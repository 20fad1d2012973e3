#pragma once
// A lab of hosts (network namespaces, deploy/lab/lab.sh) for one test: made with a name of its
// own (tvl<pid>-<n>) and removed by the destructor, also when the test fails; processes started
// on its hosts; this test process's own DDS participant placed on one of them (NetnsScope).
#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "thermovis/test/child_process.hpp"
#include "thermovis/test/data.hpp"

namespace thermovis::test {

class Lab {
 public:
  // Makes the lab (hosts named as given). Returns null and sets `why` when the machine cannot
  // make network namespaces (not root, no iproute2, a container without CAP_SYS_ADMIN).
  static std::unique_ptr<Lab> make(const std::vector<std::string>& hosts, bool multicast,
                                   std::string& why) {
    static std::atomic<int> counter{0};
    // Its own folder for the script's logs: the test may remove its folder before the lab goes.
    const auto dir = temp_dir("lab-script");
    const std::string name = "tvl" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    // Labs of earlier test processes that were killed before they could remove theirs.
    run_script(dir, {"gc"}, "gc");
    std::string list;
    for (const auto& h : hosts) list += (list.empty() ? "" : ",") + h;
    std::vector<std::string> args{"--name", name, "up", "--hosts", list};
    if (!multicast) args.push_back("--no-multicast");
    // Measurement knob: the links' MTU (jumbo frames: 9000).
    if (const char* mtu = std::getenv("THERMOVIS_LAB_MTU")) args.insert(args.end(), {"--mtu", mtu});
    std::string log;
    if (run_script(dir, args, "up", &log) != 0) {
      run_script(dir, {"--name", name, "down"}, "down");
      why = "cannot make network namespaces for the lab (needs root and iproute2): " + log;
      std::filesystem::remove_all(dir);
      return nullptr;
    }
    return std::unique_ptr<Lab>(new Lab(dir, name));
  }

  ~Lab() {
    try {
      run_script(dir_, {"--name", name_, "down"}, "down");
      std::filesystem::remove_all(dir_);
    } catch (const std::exception&) {
      // Nothing more to do here; the next lab's `gc` removes what is left.
    }
  }
  Lab(const Lab&) = delete;
  Lab& operator=(const Lab&) = delete;

  const std::string& name() const { return name_; }
  std::string ns(const std::string& host) const { return name_ + "-" + host; }

  // The address of `host` on the lab's network.
  std::string ip(const std::string& host) const {
    std::string out;
    if (run_script(dir_, {"--name", name_, "ip", host}, "ip", &out) != 0)
      throw std::runtime_error("lab: no address for host " + host + ": " + out);
    while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
    return out;
  }

  // Cuts (false) or restores (true) the cable of `host`.
  void link(const std::string& host, bool up) const {
    std::string out;
    if (run_script(dir_, {"--name", name_, "link", host, up ? "up" : "down"}, "link", &out) != 0)
      throw std::runtime_error("lab: link " + host + ": " + out);
  }

  // tc netem on `host`'s link (lab.sh shape: --rate 1gbit, --delay 1ms, --loss 0.1%).
  void shape(const std::string& host, const std::vector<std::string>& netem) const {
    std::vector<std::string> args{"--name", name_, "shape", host};
    args.insert(args.end(), netem.begin(), netem.end());
    std::string out;
    if (run_script(dir_, args, "shape", &out) != 0)
      throw std::runtime_error("lab: shape " + host + ": " + out);
  }

  // `argv` run on `host` (same pid as the program: signals reach it directly).
  std::unique_ptr<ChildProcess> start(const std::string& host, std::vector<std::string> argv,
                                      const std::filesystem::path& log,
                                      const std::map<std::string, std::string>& env = {}) const {
    std::vector<std::string> full{"/usr/bin/env", "ip", "netns", "exec", ns(host)};
    full.insert(full.end(), argv.begin(), argv.end());
    return std::make_unique<ChildProcess>(full, log, env);
  }

 private:
  Lab(std::filesystem::path dir, std::string name) : dir_(std::move(dir)), name_(std::move(name)) {}

  static int run_script(const std::filesystem::path& dir, const std::vector<std::string>& args,
                        const std::string& what, std::string* output = nullptr) {
    std::vector<std::string> argv{"/bin/bash", (source_root() / "deploy/lab/lab.sh").string()};
    argv.insert(argv.end(), args.begin(), args.end());
    const auto log = dir / ("lab-" + what + ".log");
    ChildProcess script(argv, log);
    const auto code = script.wait(std::chrono::seconds(60));
    if (output != nullptr) *output = script.log();
    return code.value_or(-1);
  }

  std::filesystem::path dir_;
  std::string name_;
};

// Moves the calling thread into a network namespace for the scope's lifetime: a DDS participant
// created inside opens its sockets there, and the threads it starts stay there. Throws when the
// namespace cannot be entered.
class NetnsScope {
 public:
  explicit NetnsScope(const std::string& ns) {
    original_ = ::open("/proc/thread-self/ns/net", O_RDONLY | O_CLOEXEC);
    const std::string path = "/run/netns/" + ns;
    const int target = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (original_ < 0 || target < 0 || ::setns(target, CLONE_NEWNET) != 0) {
      const std::string error = std::strerror(errno);
      if (target >= 0) ::close(target);
      if (original_ >= 0) ::close(original_);
      throw std::runtime_error("cannot enter network namespace " + ns + ": " + error);
    }
    ::close(target);
  }
  ~NetnsScope() {
    ::setns(original_, CLONE_NEWNET);
    ::close(original_);
  }
  NetnsScope(const NetnsScope&) = delete;
  NetnsScope& operator=(const NetnsScope&) = delete;

 private:
  int original_ = -1;
};

}  // namespace thermovis::test
