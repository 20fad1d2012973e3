#pragma once
// A lab of hosts on this machine (deploy/lab/lab.sh: one network namespace per host, linked
// through a switch), made with a name of its own and removed by the destructor, and a scope that
// places the calling thread (and the DDS participant it creates) on one of its hosts. Used by
// `thermovis bench lab` and the lab tests. Needs root (or CAP_NET_ADMIN + CAP_SYS_ADMIN).
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace thermovis::process {

// Runs argv (argv[0] a path) to its end or `timeout` (then SIGKILL); its stdout and stderr
// together in `output`. The exit code, -signal when killed, or -1 when it could not start.
int run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout,
                std::string* output = nullptr);

class Lab {
 public:
  // Makes a lab with the given hosts (and, unless `multicast` is false, a multicast route for
  // DDS discovery); `mtu` 0: lab.sh's default. Returns null and sets `why` when the machine
  // cannot make it (not root, no iproute2, a container without the capabilities).
  static std::unique_ptr<Lab> make(const std::vector<std::string>& hosts, bool multicast, int mtu,
                                   std::string& why);
  ~Lab();  // stops what runs in the lab and removes it
  Lab(const Lab&) = delete;
  Lab& operator=(const Lab&) = delete;

  const std::string& name() const { return name_; }
  // The namespace of `host`.
  std::string ns(const std::string& host) const { return name_ + "-" + host; }
  // The address of `host` on the lab's network. Throws std::runtime_error.
  std::string ip(const std::string& host) const;
  // Cuts (false) or restores (true) the cable of `host`. Throws std::runtime_error.
  void link(const std::string& host, bool up) const;
  // Limits `host`'s egress (lab.sh shape: --rate 1gbit, --delay 1ms, --loss 0.1%).
  void shape(const std::string& host, const std::vector<std::string>& netem) const;
  // argv run on `host`: `ip netns exec <ns> argv...` (same pid as the program).
  std::vector<std::string> on(const std::string& host, const std::vector<std::string>& argv) const;
  // Bytes `host` has sent on its lab link. Throws std::runtime_error.
  std::uint64_t tx_bytes(const std::string& host) const;

  // deploy/lab/lab.sh of the source tree ($THERMOVIS_LAB_SCRIPT when set).
  static std::filesystem::path script();

 private:
  explicit Lab(std::string name) : name_(std::move(name)) {}
  std::string run(const std::vector<std::string>& args, const std::string& what) const;
  std::string name_;
};

// Moves the calling thread into a network namespace for the scope's lifetime: a DDS participant
// created inside opens its sockets there, and the threads it starts stay there. Throws
// std::runtime_error when the namespace cannot be entered.
class NetnsScope {
 public:
  explicit NetnsScope(const std::string& ns);
  ~NetnsScope();
  NetnsScope(const NetnsScope&) = delete;
  NetnsScope& operator=(const NetnsScope&) = delete;

 private:
  int original_ = -1;
};

}  // namespace thermovis::process
