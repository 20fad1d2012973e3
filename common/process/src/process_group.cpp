#include "thermovis/process/process_group.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "thermovis/util/enum_names.hpp"

extern char** environ;

namespace thermovis::process {
namespace {

constexpr util::EnumName<ServiceState> kServiceStateNames[] = {
    {ServiceState::stopped, "stopped"},
    {ServiceState::running, "running"},
    {ServiceState::backoff, "restarting"},
    {ServiceState::failed, "failed"}};

using Seconds = std::chrono::duration<double>;

std::string describe_wait_status(int wait_status, int& code) {
  if (WIFEXITED(wait_status)) {
    code = WEXITSTATUS(wait_status);
    return "exited with code " + std::to_string(code);
  }
  if (WIFSIGNALED(wait_status)) {
    code = -WTERMSIG(wait_status);
    return std::string("killed by signal ") + strsignal(WTERMSIG(wait_status));
  }
  code = -1;
  return "stopped";
}

}  // namespace

const char* to_string(ServiceState state) { return util::name_of(kServiceStateNames, state, "?"); }

ProcessGroup::ProcessGroup(Manifest manifest, ProcessGroupOptions options)
    : options_(std::move(options)) {
  for (const auto& name : start_order(manifest)) {
    const auto it = std::find_if(manifest.services.begin(), manifest.services.end(),
                                 [&](const ServiceSpec& s) { return s.name == name; });
    if (it->command.empty()) {
      throw std::invalid_argument("manifest: service '" + name + "' has an empty command");
    }
    Entry entry;
    entry.spec = *it;
    entry.status.name = name;
    entries_.push_back(std::move(entry));
  }
  if (!options_.log_dir.empty()) std::filesystem::create_directories(options_.log_dir);
}

ProcessGroup::~ProcessGroup() { stop_all(); }

ProcessGroup::Entry& ProcessGroup::entry(const std::string& name) {
  for (auto& e : entries_) {
    if (e.spec.name == name) return e;
  }
  throw std::out_of_range("no service named '" + name + "'");
}

const ServiceStatus& ProcessGroup::status(const std::string& name) const {
  for (const auto& e : entries_) {
    if (e.spec.name == name) return e.status;
  }
  throw std::out_of_range("no service named '" + name + "'");
}

std::vector<ServiceStatus> ProcessGroup::status() const {
  std::vector<ServiceStatus> out;
  for (const auto& e : entries_) out.push_back(e.status);
  return out;
}

void ProcessGroup::spawn(Entry& e) {
  std::vector<std::string> argv;
  for (const auto& arg : e.spec.command) argv.push_back(substitute(arg, options_.vars));
  std::vector<std::string> env;
  for (char** p = environ; *p != nullptr; ++p) {
    const std::string var = *p;
    const std::string key = var.substr(0, var.find('='));
    if (!e.spec.env.count(key)) env.push_back(var);
  }
  for (const auto& [key, value] : e.spec.env)
    env.push_back(key + "=" + substitute(value, options_.vars));
  std::vector<char*> c_argv, c_env;
  for (auto& a : argv) c_argv.push_back(a.data());
  c_argv.push_back(nullptr);
  for (auto& v : env) c_env.push_back(v.data());
  c_env.push_back(nullptr);
  e.status.log = options_.log_dir.empty() ? std::filesystem::path("/dev/null")
                                          : options_.log_dir / (e.spec.name + ".log");
  const std::string log = e.status.log.string();

  // Written by the child if its realtime policy is refused (composed here: the child of a
  // threaded process must not allocate between fork and exec).
  const std::string realtime_refused =
      "thermovis-supervisor: realtime priority " + std::to_string(e.spec.realtime) +
      " refused (needs CAP_SYS_NICE or an rtprio limit, docs/deployment.md): runs at the normal "
      "policy\n";

  // exec failures travel back through a close-on-exec pipe.
  int report[2];
  if (pipe2(report, O_CLOEXEC) != 0)
    throw std::runtime_error("pipe: " + std::string(strerror(errno)));
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork: " + std::string(strerror(errno)));
  if (pid == 0) {
    // Child: own process group (so a stop reaches its children too), die with the supervisor.
    setpgid(0, 0);
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(127);
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    const int null_in = open("/dev/null", O_RDONLY);
    if (null_in >= 0) dup2(null_in, STDIN_FILENO);
    // Relative, as nice(1): a service niced by 10 stays 10 below the supervisor.
    if (e.spec.nice != 0)
      (void)!setpriority(PRIO_PROCESS, 0, getpriority(PRIO_PROCESS, 0) + e.spec.nice);
    if (e.spec.idle) {
      const sched_param idle{};
      (void)!sched_setscheduler(0, SCHED_IDLE, &idle);
    }
    if (e.spec.realtime > 0) {
      sched_param fifo{};
      fifo.sched_priority = e.spec.realtime;
      if (sched_setscheduler(0, SCHED_FIFO, &fifo) != 0) {
        // Into the service's log, before its own lines: it runs, at the normal policy.
        (void)!write(STDERR_FILENO, realtime_refused.data(), realtime_refused.size());
      }
    }
    execvpe(c_argv[0], c_argv.data(), c_env.data());
    const int err = errno;
    (void)!write(report[1], &err, sizeof(err));
    _exit(127);
  }
  close(report[1]);
  int err = 0;
  const ssize_t got = read(report[0], &err, sizeof(err));
  close(report[0]);
  if (got == static_cast<ssize_t>(sizeof(err))) {
    waitpid(pid, nullptr, 0);
    e.status.state = ServiceState::failed;
    e.status.pid = -1;
    e.status.last_error = "cannot execute '" + argv[0] + "': " + strerror(err);
    throw std::runtime_error("service '" + e.spec.name + "': " + e.status.last_error);
  }
  e.status.pid = pid;
  e.status.state = ServiceState::running;
  e.started = Clock::now();
}

void ProcessGroup::start_all() {
  stopping_ = false;
  for (auto& e : entries_) {
    if (e.status.state != ServiceState::running) spawn(e);
  }
}

void ProcessGroup::handle_exit(Entry& e, int wait_status) {
  int code = 0;
  const std::string what = describe_wait_status(wait_status, code);
  e.status.pid = -1;
  e.status.last_exit_code = code;
  e.status.last_error = what;
  const bool failed = code != 0;
  const bool restart = !stopping_ && (e.spec.restart == RestartPolicy::always ||
                                      (e.spec.restart == RestartPolicy::on_failure && failed));
  if (!restart) {
    e.status.state = failed ? ServiceState::failed : ServiceState::stopped;
    if (!stopping_) report(e, what + (failed ? "; not restarted (policy)" : ""));
    return;
  }
  const double ran_s = Seconds(Clock::now() - e.started).count();
  e.consecutive_failures = ran_s >= e.spec.stable_after_s ? 1 : e.consecutive_failures + 1;
  const double delay = std::min(
      e.spec.backoff_max_s, e.spec.backoff_initial_s * std::pow(2.0, e.consecutive_failures - 1));
  e.restart_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(Seconds(delay));
  e.status.state = ServiceState::backoff;
  std::ostringstream event;
  event << what << "; restart " << e.status.restarts + 1 << " in " << delay << " s";
  report(e, event.str());
}

void ProcessGroup::report(const Entry& e, const std::string& event) const {
  if (options_.on_event) options_.on_event(e.spec.name, event);
}

void ProcessGroup::poll() {
  for (auto& e : entries_) {
    if (e.status.state == ServiceState::running && e.status.pid > 0) {
      int wait_status = 0;
      const pid_t got = waitpid(e.status.pid, &wait_status, WNOHANG);
      if (got == e.status.pid) handle_exit(e, wait_status);
    }
    if (e.status.state == ServiceState::backoff && !stopping_ && Clock::now() >= e.restart_at) {
      ++e.status.restarts;
      try {
        spawn(e);
      } catch (const std::exception& error) {
        report(e, error.what());
        // The status already says why; retry after the longest backoff.
        e.status.state = ServiceState::backoff;
        e.restart_at = Clock::now() +
                       std::chrono::duration_cast<Clock::duration>(Seconds(e.spec.backoff_max_s));
      }
    }
  }
}

void ProcessGroup::stop_one(Entry& e) {
  if (e.status.pid <= 0) return;
  kill(-e.status.pid, SIGTERM);
  kill(e.status.pid, SIGTERM);
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(Seconds(e.spec.stop_timeout_s));
  int wait_status = 0;
  for (;;) {
    const pid_t got = waitpid(e.status.pid, &wait_status, WNOHANG);
    if (got == e.status.pid || got < 0) break;
    if (Clock::now() >= deadline) {
      kill(-e.status.pid, SIGKILL);
      kill(e.status.pid, SIGKILL);
      waitpid(e.status.pid, &wait_status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  int code = 0;
  e.status.last_error = describe_wait_status(wait_status, code);
  e.status.last_exit_code = code;
  e.status.pid = -1;
  // A service that ends on our SIGTERM (handled or not) stopped as asked.
  e.status.state = (code == 0 || code == -SIGTERM) ? ServiceState::stopped : ServiceState::failed;
}

void ProcessGroup::restart(const std::string& name, const std::string& reason) {
  Entry& e = entry(name);
  stop_one(e);
  e.status.last_error = reason;
  ++e.status.restarts;
  report(e, reason + "; restart " + std::to_string(e.status.restarts) + " now");
  spawn(e);
}

void ProcessGroup::stop_all() {
  stopping_ = true;
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    stop_one(*it);
    if (it->status.state == ServiceState::backoff) it->status.state = ServiceState::stopped;
  }
}

}  // namespace thermovis::process
