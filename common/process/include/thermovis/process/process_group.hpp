#pragma once
// Starts, watches, restarts (with exponential backoff) and stops the processes of a manifest.
// Single-threaded: the owner calls poll() regularly (e.g. every 10-50 ms). POSIX only.
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "thermovis/process/manifest.hpp"

namespace thermovis::process {

enum class ServiceState { stopped, running, backoff, failed };
const char* to_string(ServiceState state);

struct ServiceStatus {
  std::string name;
  ServiceState state = ServiceState::stopped;
  pid_t pid = -1;
  int restarts = 0;
  int last_exit_code = 0;     // exit status, or -signal when killed by a signal
  std::string last_error;     // why it last stopped, in words
  std::filesystem::path log;  // its stdout + stderr
};

struct ProcessGroupOptions {
  std::map<std::string, std::string> vars;  // for ${...} substitution (bin, config, domain, ...)
  std::filesystem::path log_dir;            // one <name>.log per service; created if missing
  // Told of every exit, restart and failed start, in words (for the supervisor's log); optional.
  std::function<void(const std::string& service, const std::string& event)> on_event;
};

class ProcessGroup {
 public:
  using Clock = std::chrono::steady_clock;

  ProcessGroup(Manifest manifest, ProcessGroupOptions options);
  ~ProcessGroup();  // stops everything still running
  ProcessGroup(const ProcessGroup&) = delete;
  ProcessGroup& operator=(const ProcessGroup&) = delete;

  // Starts every service in dependency order. Throws std::runtime_error when a command cannot be
  // executed at all (missing executable), naming the service and the command.
  void start_all();
  // Reaps exited children and restarts those whose policy says so, once their backoff expires.
  void poll();
  // Restarts one service now (used when it is alive but hung: no heartbeat).
  void restart(const std::string& name, const std::string& reason);
  // SIGTERM to all (reverse start order), SIGKILL to those still alive after their stop timeout.
  void stop_all();

  std::vector<ServiceStatus> status() const;
  const ServiceStatus& status(const std::string& name) const;

 private:
  struct Entry {
    ServiceSpec spec;
    ServiceStatus status;
    Clock::time_point started{};
    Clock::time_point restart_at{};
    int consecutive_failures = 0;
  };
  void spawn(Entry& entry);
  void handle_exit(Entry& entry, int wait_status);
  void stop_one(Entry& entry);
  Entry& entry(const std::string& name);
  void report(const Entry& entry, const std::string& event) const;

  std::vector<Entry> entries_;  // in start order
  ProcessGroupOptions options_;
  bool stopping_ = false;
};

}  // namespace thermovis::process
