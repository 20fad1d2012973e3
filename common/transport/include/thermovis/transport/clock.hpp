#pragma once
// The clock of every *_ns stamp in thermovis messages: nanoseconds since the Unix epoch
// (CLOCK_REALTIME), comparable between processes and, with synchronised clocks, hosts.
#include <chrono>
#include <cstdint>

namespace thermovis::transport {

inline std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace thermovis::transport
