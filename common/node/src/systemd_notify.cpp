#include "thermovis/node/systemd_notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace thermovis::node {

SystemdNotifier::SystemdNotifier() {
  if (const char* path = std::getenv("NOTIFY_SOCKET"); path != nullptr) socket_ = path;
  if (const char* usec = std::getenv("WATCHDOG_USEC"); usec != nullptr) {
    const long long value = std::atoll(usec);
    if (value > 0) watchdog_period_ = std::chrono::microseconds(value);
  }
}

bool SystemdNotifier::send(const std::string& message) const {
  if (socket_.empty()) return false;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (socket_.size() >= sizeof(address.sun_path)) return false;
  std::memcpy(address.sun_path, socket_.data(), socket_.size());
  if (address.sun_path[0] == '@') address.sun_path[0] = '\0';  // abstract namespace
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  const auto length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + socket_.size());
  const ssize_t sent = ::sendto(fd, message.data(), message.size(), MSG_NOSIGNAL,
                                reinterpret_cast<const sockaddr*>(&address), length);
  ::close(fd);
  return sent == static_cast<ssize_t>(message.size());
}

void SystemdNotifier::ready(const std::string& status) {
  if (ready_sent_ || !enabled()) return;
  ready_sent_ = send(status.empty() ? "READY=1" : "READY=1\nSTATUS=" + status);
  last_ping_ = std::chrono::steady_clock::now();
}

void SystemdNotifier::watchdog() {
  if (!enabled() || watchdog_period_.count() == 0) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ping_ < watchdog_period_ / 2) return;
  send("WATCHDOG=1");
  last_ping_ = now;
}

void SystemdNotifier::stopping() { send("STOPPING=1"); }

}  // namespace thermovis::node
