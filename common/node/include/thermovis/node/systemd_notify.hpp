#pragma once
// The systemd service notification protocol (sd_notify(3)) without libsystemd: a datagram to the
// socket named by $NOTIFY_SOCKET. Services run by systemd with Type=notify report READY=1 once
// they serve, and WATCHDOG=1 from their processing loop when the unit sets WatchdogSec (systemd
// passes $WATCHDOG_USEC): a loop that hangs stops the pings and systemd restarts the service.
// Without $NOTIFY_SOCKET (not under systemd) every call does nothing.
#include <chrono>
#include <string>

namespace thermovis::node {

class SystemdNotifier {
 public:
  SystemdNotifier();  // reads $NOTIFY_SOCKET and $WATCHDOG_USEC
  bool enabled() const { return !socket_.empty(); }
  // Sends READY=1 once (later calls do nothing).
  void ready(const std::string& status = "");
  // Sends WATCHDOG=1 when half the watchdog period has passed since the last ping.
  void watchdog();
  // Sends STOPPING=1.
  void stopping();

 private:
  bool send(const std::string& message) const;

  std::string socket_;
  std::chrono::microseconds watchdog_period_{0};
  std::chrono::steady_clock::time_point last_ping_{};
  bool ready_sent_ = false;
};

}  // namespace thermovis::node
