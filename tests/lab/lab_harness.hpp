#pragma once
// A lab of hosts (process::Lab over deploy/lab/lab.sh) for one test: made with a name of its own
// and removed by the destructor, also when the test fails; processes started on its hosts as
// ChildProcess; this test process's own DDS participant placed on one of them (NetnsScope).
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "thermovis/process/lab.hpp"
#include "thermovis/test/child_process.hpp"

namespace thermovis::test {

using NetnsScope = process::NetnsScope;

class Lab {
 public:
  // Makes the lab (hosts named as given). Returns null and sets `why` when the machine cannot
  // make network namespaces (not root, no iproute2, a container without CAP_SYS_ADMIN).
  static std::unique_ptr<Lab> make(const std::vector<std::string>& hosts, bool multicast,
                                   std::string& why) {
    // Measurement knob: the links' MTU (jumbo frames: 9000).
    const char* mtu = std::getenv("THERMOVIS_LAB_MTU");
    auto lab = process::Lab::make(hosts, multicast, mtu != nullptr ? std::atoi(mtu) : 0, why);
    return lab ? std::unique_ptr<Lab>(new Lab(std::move(lab))) : nullptr;
  }

  std::string ns(const std::string& host) const { return lab_->ns(host); }
  std::string ip(const std::string& host) const { return lab_->ip(host); }
  void link(const std::string& host, bool up) const { lab_->link(host, up); }
  void shape(const std::string& host, const std::vector<std::string>& netem) const {
    lab_->shape(host, netem);
  }
  std::uint64_t tx_bytes(const std::string& host) const { return lab_->tx_bytes(host); }

  // `argv` run on `host` (same pid as the program: signals reach it directly).
  std::unique_ptr<ChildProcess> start(const std::string& host, std::vector<std::string> argv,
                                      const std::filesystem::path& log,
                                      const std::map<std::string, std::string>& env = {}) const {
    return std::make_unique<ChildProcess>(lab_->on(host, argv), log, env);
  }

 private:
  explicit Lab(std::unique_ptr<process::Lab> lab) : lab_(std::move(lab)) {}
  std::unique_ptr<process::Lab> lab_;
};

}  // namespace thermovis::test
