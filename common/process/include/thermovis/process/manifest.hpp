#pragma once
// The pipeline manifest (deploy/pipeline.yaml): which service processes to run, how to start them,
// in which order and what to do when one exits. Plain data; parsing is in manifest_io.hpp.
#include <map>
#include <string>
#include <vector>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::process {

enum class RestartPolicy { always, on_failure, never };
// Their names in the manifest (restart: on-failure) and in status reports.
inline constexpr util::EnumName<RestartPolicy> kRestartPolicyNames[] = {
    {RestartPolicy::always, "always"},
    {RestartPolicy::on_failure, "on-failure"},
    {RestartPolicy::never, "never"}};

struct ServiceSpec {
  std::string name;                        // unique, e.g. "bridge"
  std::vector<std::string> command;        // argv; ${bin}, ${config}, ${domain} are substituted
  std::map<std::string, std::string> env;  // extra environment (same substitutions)
  RestartPolicy restart = RestartPolicy::on_failure;
  std::vector<std::string> depends_on;  // started after these
  double backoff_initial_s = 0.1;       // first restart delay; doubles per consecutive failure
  double backoff_max_s = 5.0;           // restart delay ceiling
  double stable_after_s = 10.0;         // running this long resets the backoff
  double stop_timeout_s = 3.0;          // SIGTERM -> SIGKILL grace
  // Scheduling of the process and what it starts: its niceness, added to the supervisor's as
  // nice(1) does (0: the same; the kernel keeps the sum within -20..19), or
  // `idle` (SCHED_IDLE: it runs only on CPU time nothing else wants, whatever niceness it sets
  // itself, as Chromium does). For best-effort consumers such as a display, so that the
  // pipeline's stages take the CPU first.
  int nice = 0;
  bool idle = false;
  // `realtime` N in 1..99: SCHED_FIFO at priority N (0: the normal policy), for the stages a
  // capture waits for. Such a process is not preempted by the machine's other work (a
  // best-effort display, the kernel's housekeeping threads, other programs); it needs
  // CAP_SYS_NICE or an RLIMIT_RTPRIO of N (limits.conf `rtprio`), and without it the service
  // runs at the normal policy and says so in its log. Its threads inherit it.
  int realtime = 0;
};

struct Manifest {
  std::string name;
  std::vector<ServiceSpec> services;  // in start order (dependencies first), see start_order()
};

// Service names in an order where every service follows its dependencies. Throws
// std::invalid_argument on an unknown dependency or a cycle, naming it.
std::vector<std::string> start_order(const Manifest& manifest);

// Replaces ${key} in text by vars[key]; unknown keys are left as they are.
std::string substitute(const std::string& text, const std::map<std::string, std::string>& vars);

const char* to_string(RestartPolicy policy);

}  // namespace thermovis::process
