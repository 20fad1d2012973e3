// Real child processes: restart with backoff, policies, stop, kill -9, missing executables.
#include <gtest/gtest.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/process/process_group.hpp"
#include "thermovis/test/data.hpp"

namespace tp = thermovis::process;
using namespace std::chrono_literals;

namespace {

tp::ServiceSpec service(const std::string& name, std::vector<std::string> command,
                        tp::RestartPolicy restart) {
  tp::ServiceSpec spec;
  spec.name = name;
  spec.command = std::move(command);
  spec.restart = restart;
  spec.backoff_initial_s = 0.02;
  spec.backoff_max_s = 0.08;
  spec.stop_timeout_s = 1.0;
  return spec;
}

// Polls until pred() or the timeout; returns pred().
template <typename Pred>
bool poll_until(tp::ProcessGroup& group, Pred pred, std::chrono::milliseconds timeout = 5000ms) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    group.poll();
    if (pred()) return true;
    std::this_thread::sleep_for(5ms);
  }
  return pred();
}

TEST(ProcessGroup, FailingServiceIsRestartedWithBackoffAndLogsItsOutput) {
  const auto dir = thermovis::test::temp_dir("pg-restart");
  tp::Manifest m;
  m.services.push_back(service("flaky", {"/bin/sh", "-c", "echo started ${word}; exit 3"},
                               tp::RestartPolicy::on_failure));
  std::vector<std::string> events;
  tp::ProcessGroup group(
      m, {{{"word", "here"}}, dir, [&](const std::string& name, const std::string& event) {
            events.push_back(name + ": " + event);
          }});
  group.start_all();
  ASSERT_TRUE(poll_until(group, [&] { return group.status("flaky").restarts >= 3; }));
  const auto& st = group.status("flaky");
  EXPECT_EQ(st.last_exit_code, 3);
  EXPECT_NE(st.last_error.find("code 3"), std::string::npos) << st.last_error;
  // Each exit is reported with its cause and the restart it leads to.
  ASSERT_GE(events.size(), 3u);
  EXPECT_NE(events[0].find("flaky: "), std::string::npos) << events[0];
  EXPECT_NE(events[0].find("code 3"), std::string::npos) << events[0];
  EXPECT_NE(events[0].find("restart 1 in"), std::string::npos) << events[0];
  EXPECT_NE(events[2].find("restart 3 in"), std::string::npos) << events[2];
  group.stop_all();
  std::ifstream log(dir / "flaky.log");
  std::string first;
  std::getline(log, first);
  EXPECT_EQ(first, "started here");
  std::filesystem::remove_all(dir);
}

TEST(ProcessGroup, PoliciesDecideWhatHappensOnExit) {
  tp::Manifest m;
  m.services.push_back(service("once", {"/bin/sh", "-c", "exit 0"}, tp::RestartPolicy::on_failure));
  m.services.push_back(service("never", {"/bin/sh", "-c", "exit 1"}, tp::RestartPolicy::never));
  m.services.push_back(service("always", {"/bin/sh", "-c", "exit 0"}, tp::RestartPolicy::always));
  tp::ProcessGroup group(m, {});
  group.start_all();
  ASSERT_TRUE(poll_until(group, [&] { return group.status("always").restarts >= 2; }));
  EXPECT_EQ(group.status("once").state, tp::ServiceState::stopped);
  EXPECT_EQ(group.status("once").restarts, 0);
  EXPECT_EQ(group.status("never").state, tp::ServiceState::failed);
  EXPECT_EQ(group.status("never").restarts, 0);
}

TEST(ProcessGroup, KilledServiceComesBackAndOthersKeepRunning) {
  tp::Manifest m;
  m.services.push_back(service("a", {"/bin/sleep", "30"}, tp::RestartPolicy::on_failure));
  m.services.push_back(service("b", {"/bin/sleep", "30"}, tp::RestartPolicy::on_failure));
  tp::ProcessGroup group(m, {});
  group.start_all();
  const pid_t a_pid = group.status("a").pid;
  const pid_t b_pid = group.status("b").pid;
  ASSERT_GT(a_pid, 0);
  ASSERT_EQ(kill(a_pid, SIGKILL), 0);
  ASSERT_TRUE(poll_until(group, [&] {
    return group.status("a").state == tp::ServiceState::running && group.status("a").pid != a_pid;
  }));
  EXPECT_EQ(group.status("a").restarts, 1);
  EXPECT_NE(group.status("a").last_error.find("signal"), std::string::npos);
  EXPECT_EQ(group.status("b").pid, b_pid);
  group.stop_all();
  EXPECT_EQ(group.status("a").state, tp::ServiceState::stopped);
  EXPECT_EQ(group.status("b").state, tp::ServiceState::stopped);
  EXPECT_NE(kill(b_pid, 0), 0);  // really gone
}

// A best-effort service (a display) runs with the niceness or the idle policy its spec gives, and
// what it starts inherits them.
TEST(ProcessGroup, ServicesRunWithTheirNicenessOrTheIdlePolicy) {
  tp::Manifest m;
  m.services.push_back(service("plain", {"/bin/sleep", "30"}, tp::RestartPolicy::never));
  m.services.push_back(service("nice", {"/bin/sleep", "30"}, tp::RestartPolicy::never));
  m.services.back().nice = 10;
  m.services.push_back(service("idle", {"/bin/sleep", "30"}, tp::RestartPolicy::never));
  m.services.back().idle = true;
  tp::ProcessGroup group(m, {});
  group.start_all();
  // The exec'd program's niceness and policy (the child sets them between fork and exec).
  const auto settle = [&](const char* name) {
    const pid_t pid = group.status(name).pid;
    poll_until(group, [&] {
      std::ifstream comm("/proc/" + std::to_string(pid) + "/comm");
      std::string text;
      return std::getline(comm, text) && text == "sleep";
    });
    return pid;
  };
  const pid_t plain = settle("plain"), niced = settle("nice"), idle = settle("idle");
  errno = 0;
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(niced)),
            getpriority(PRIO_PROCESS, 0) + 10 > 19 ? 19 : getpriority(PRIO_PROCESS, 0) + 10);
  EXPECT_EQ(getpriority(PRIO_PROCESS, static_cast<id_t>(plain)), getpriority(PRIO_PROCESS, 0));
  EXPECT_EQ(sched_getscheduler(idle), SCHED_IDLE);
  EXPECT_EQ(sched_getscheduler(plain), sched_getscheduler(0));
  group.stop_all();
}

namespace {

// Starts one `realtime: 7` service (/bin/sleep) in `log_dir` and returns what it runs with: the
// policy, the priority and its log's text (the child writes a refusal there).
struct RealtimeOutcome {
  int policy = -1;
  int priority = -1;
  std::string log;
};
RealtimeOutcome start_realtime_service(const std::filesystem::path& log_dir) {
  tp::Manifest m;
  m.services.push_back(service("fast", {"/bin/sleep", "30"}, tp::RestartPolicy::never));
  m.services.back().realtime = 7;
  tp::ProcessGroup group(m, {{}, log_dir, {}});
  group.start_all();
  const pid_t pid = group.status("fast").pid;
  poll_until(group, [&] {
    std::ifstream comm("/proc/" + std::to_string(pid) + "/comm");
    std::string text;
    return std::getline(comm, text) && text == "sleep";
  });
  RealtimeOutcome out;
  out.policy = sched_getscheduler(pid);
  sched_param param{};
  if (sched_getparam(pid, &param) == 0) out.priority = param.sched_priority;
  group.stop_all();
  std::ifstream log(log_dir / "fast.log");
  out.log.assign(std::istreambuf_iterator<char>(log), std::istreambuf_iterator<char>());
  return out;
}

// Whether this process may take SCHED_FIFO (tried in a child that exits at once).
bool fifo_permitted() {
  const pid_t pid = fork();
  if (pid == 0) {
    sched_param fifo{};
    fifo.sched_priority = 7;
    _exit(sched_setscheduler(0, SCHED_FIFO, &fifo) == 0 ? 0 : 1);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

}  // namespace

// A frame-path stage runs SCHED_FIFO at its priority where that is permitted; where it is not,
// it still runs, at the normal policy, and its log says why.
TEST(ProcessGroup, RealtimeServicesRunFifoOrSayWhyNot) {
  const auto dir = thermovis::test::temp_dir("process_group_realtime");
  const RealtimeOutcome here = start_realtime_service(dir / "here");
  if (fifo_permitted()) {
    EXPECT_EQ(here.policy, SCHED_FIFO);
    EXPECT_EQ(here.priority, 7);
    EXPECT_EQ(here.log.find("refused"), std::string::npos) << here.log;
  } else {
    EXPECT_EQ(here.policy, SCHED_OTHER);
    EXPECT_NE(here.log.find("realtime priority 7 refused"), std::string::npos) << here.log;
  }
  if (geteuid() != 0) return;  // the refusal is covered above
  // As an unprivileged user (nobody: no CAP_SYS_NICE, rtprio limit 0), in a child process.
  std::filesystem::create_directories(dir / "nobody");
  std::filesystem::permissions(dir / "nobody", std::filesystem::perms::all);
  const pid_t pid = fork();
  if (pid == 0) {
    if (setgid(65534) != 0 || setuid(65534) != 0) _exit(2);
    const RealtimeOutcome nobody = start_realtime_service(dir / "nobody");
    const bool refused = nobody.policy == SCHED_OTHER &&
                         nobody.log.find("realtime priority 7 refused") != std::string::npos;
    _exit(refused ? 0 : 1);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "as nobody: 1 = not refused or not logged, 2 = setuid";
}

TEST(ProcessGroup, ServiceIgnoringSigtermIsKilledAfterItsTimeout) {
  tp::Manifest m;
  auto spec =
      service("stubborn", {"/bin/sh", "-c", "trap '' TERM; while true; do sleep 0.05; done"},
              tp::RestartPolicy::never);
  spec.stop_timeout_s = 0.3;
  m.services.push_back(spec);
  tp::ProcessGroup group(m, {});
  group.start_all();
  std::this_thread::sleep_for(100ms);
  const pid_t pid = group.status("stubborn").pid;
  group.stop_all();
  EXPECT_EQ(group.status("stubborn").state, tp::ServiceState::failed);
  EXPECT_NE(kill(pid, 0), 0);
}

TEST(ProcessGroup, MissingExecutableIsNamed) {
  tp::Manifest m;
  m.services.push_back(
      service("ghost", {"/nonexistent/thermovis-ghost"}, tp::RestartPolicy::never));
  tp::ProcessGroup group(m, {});
  try {
    group.start_all();
    FAIL() << "missing executable accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ghost"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/nonexistent/thermovis-ghost"), std::string::npos);
  }
}

}  // namespace
