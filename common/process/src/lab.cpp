#include "thermovis/process/lab.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace thermovis::process {

int run_command(const std::vector<std::string>& argv, std::chrono::milliseconds timeout,
                std::string* output) {
  int fds[2];
  if (argv.empty() || ::pipe2(fds, O_CLOEXEC) != 0) return -1;
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    return -1;
  }
  if (pid == 0) {
    ::dup2(fds[1], STDOUT_FILENO);
    ::dup2(fds[1], STDERR_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  std::string out;
  const auto until = std::chrono::steady_clock::now() + timeout;
  bool killed = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        until - std::chrono::steady_clock::now());
    if (left.count() <= 0 && !killed) {
      ::kill(pid, SIGKILL);
      killed = true;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, killed ? 1000 : static_cast<int>(left.count()));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) {
      if (killed) break;
      continue;
    }
    char buffer[4096];
    const ssize_t n = ::read(fds[0], buffer, sizeof(buffer));
    if (n <= 0) break;
    out.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (output != nullptr) *output = out;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return WIFSIGNALED(status) ? -WTERMSIG(status) : -1;
}

std::filesystem::path Lab::script() {
  if (const char* env = std::getenv("THERMOVIS_LAB_SCRIPT"); env != nullptr && *env != '\0')
    return env;
  return std::filesystem::path(THERMOVIS_SOURCE_DIR) / "deploy/lab/lab.sh";
}

namespace {

constexpr std::chrono::seconds kScriptTimeout{60};

int run_script(const std::vector<std::string>& args, std::string* output) {
  std::vector<std::string> argv{"/bin/bash", Lab::script().string()};
  argv.insert(argv.end(), args.begin(), args.end());
  return run_command(argv, kScriptTimeout, output);
}

}  // namespace

std::unique_ptr<Lab> Lab::make(const std::vector<std::string>& hosts, bool multicast, int mtu,
                               std::string& why) {
  static std::atomic<int> counter{0};
  const std::string name = "tvl" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  // Labs of earlier processes that were killed before they could remove theirs.
  run_script({"gc"}, nullptr);
  std::string list;
  for (const auto& h : hosts) list += (list.empty() ? "" : ",") + h;
  std::vector<std::string> args{"--name", name, "up", "--hosts", list};
  if (!multicast) args.push_back("--no-multicast");
  if (mtu > 0) args.insert(args.end(), {"--mtu", std::to_string(mtu)});
  std::string log;
  if (run_script(args, &log) != 0) {
    run_script({"--name", name, "down"}, nullptr);
    why = "cannot make network namespaces for the lab (needs root and iproute2): " + log;
    return nullptr;
  }
  return std::unique_ptr<Lab>(new Lab(name));
}

Lab::~Lab() { run_script({"--name", name_, "down"}, nullptr); }

std::string Lab::run(const std::vector<std::string>& args, const std::string& what) const {
  std::vector<std::string> full{"--name", name_};
  full.insert(full.end(), args.begin(), args.end());
  std::string out;
  if (run_script(full, &out) != 0) throw std::runtime_error("lab: " + what + ": " + out);
  return out;
}

std::string Lab::ip(const std::string& host) const {
  std::string out = run({"ip", host}, "no address for host " + host);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return out;
}

void Lab::link(const std::string& host, bool up) const {
  run({"link", host, up ? "up" : "down"}, "link " + host);
}

void Lab::shape(const std::string& host, const std::vector<std::string>& netem) const {
  std::vector<std::string> args{"shape", host};
  args.insert(args.end(), netem.begin(), netem.end());
  run(args, "shape " + host);
}

std::vector<std::string> Lab::on(const std::string& host,
                                 const std::vector<std::string>& argv) const {
  std::vector<std::string> full{"/usr/bin/env", "ip", "netns", "exec", ns(host)};
  full.insert(full.end(), argv.begin(), argv.end());
  return full;
}

std::uint64_t Lab::tx_bytes(const std::string& host) const {
  std::string out;
  const int code = run_command({"/usr/bin/env", "ip", "netns", "exec", ns(host), "cat",
                                "/sys/class/net/eth0/statistics/tx_bytes"},
                               kScriptTimeout, &out);
  if (code != 0) throw std::runtime_error("lab: no link statistics of host " + host + ": " + out);
  return std::strtoull(out.c_str(), nullptr, 10);
}

NetnsScope::NetnsScope(const std::string& ns) {
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

NetnsScope::~NetnsScope() {
  ::setns(original_, CLONE_NEWNET);
  ::close(original_);
}

}  // namespace thermovis::process
