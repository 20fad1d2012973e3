#include "pool_lifetime.hpp"

#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace thermovis::transport::detail {
namespace {

using Clock = std::chrono::steady_clock;

// Samples of a departed writer may still sit unread in a reader's history (Fast DDS checks
// them in the pool at take()); every service takes at least every 100 ms.
constexpr auto kGrace = std::chrono::seconds(2);

struct Deferred {
  void* address = nullptr;
  std::size_t length = 0;
  Clock::time_point requested;
  std::uint64_t first_later_ticket = 0;  // loans with a smaller ticket were taken before
};

struct State {
  std::mutex mutex;
  std::vector<Deferred> deferred;
  std::multiset<std::uint64_t> live;  // tickets of loans not returned yet
  std::uint64_t next_ticket = 1;
  std::uint64_t deferred_count = 0, released_count = 0;
};

State& state() {
  static State* s = new State;  // never destroyed: munmap may run during exit
  return *s;
}

int kernel_munmap(void* address, std::size_t length) {
  return static_cast<int>(syscall(SYS_munmap, address, length));
}

// True when [address, address + length) is exactly one read-only shared mapping of a Fast DDS
// data-sharing segment (how a reader maps a writer's pool; writers map theirs read-write).
bool is_reader_pool_mapping(void* address, std::size_t length) {
  const int fd = open("/proc/self/maps", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  std::string text;
  char buffer[65536];
  for (ssize_t n; (n = read(fd, buffer, sizeof(buffer))) > 0;) text.append(buffer, n);
  close(fd);
  const auto begin = reinterpret_cast<std::uintptr_t>(address);
  std::size_t line_start = 0;
  while (line_start < text.size()) {
    std::size_t line_end = text.find('\n', line_start);
    if (line_end == std::string::npos) line_end = text.size();
    const std::string line = text.substr(line_start, line_end - line_start);
    line_start = line_end + 1;
    // "begin-end perms offset dev inode path"
    char* rest = nullptr;
    const std::uintptr_t b = std::strtoull(line.c_str(), &rest, 16);
    if (b != begin || rest == nullptr || *rest != '-') continue;
    const std::uintptr_t e = std::strtoull(rest + 1, &rest, 16);
    // The kernel maps whole pages; Fast DDS passes the segment's own size.
    const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    return e - b == ((length + page - 1) & ~(page - 1)) &&
           line.find(" r--s ") != std::string::npos &&
           line.find("/dev/shm/fast_datasharing_") != std::string::npos;
  }
  return false;
}

// Unmaps what may go; the caller holds the mutex.
void release_locked(State& s) {
  const auto now = Clock::now();
  const std::uint64_t oldest_live = s.live.empty() ? UINT64_MAX : *s.live.begin();
  for (auto it = s.deferred.begin(); it != s.deferred.end();) {
    if (now - it->requested >= kGrace && oldest_live >= it->first_later_ticket) {
      kernel_munmap(it->address, it->length);
      ++s.released_count;
      it = s.deferred.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace

std::uint64_t loan_taken() {
  State& s = state();
  const std::lock_guard lock(s.mutex);
  const std::uint64_t ticket = s.next_ticket++;
  s.live.insert(ticket);
  return ticket;
}

void loan_returned(std::uint64_t ticket) noexcept {
  State& s = state();
  const std::lock_guard lock(s.mutex);
  const auto it = s.live.find(ticket);
  if (it != s.live.end()) s.live.erase(it);
  if (!s.deferred.empty()) release_locked(s);
}

void release_deferred_unmaps() noexcept {
  State& s = state();
  const std::lock_guard lock(s.mutex);
  if (!s.deferred.empty()) release_locked(s);
}

DeferredUnmaps deferred_unmaps() {
  State& s = state();
  const std::lock_guard lock(s.mutex);
  return {s.deferred.size(), s.deferred_count, s.released_count};
}

// Called by the interposed munmap: true when the unmapping was deferred.
bool defer_unmap(void* address, std::size_t length) {
  if (!is_reader_pool_mapping(address, length)) return false;
  State& s = state();
  const std::lock_guard lock(s.mutex);
  s.deferred.push_back({address, length, Clock::now(), s.next_ticket});
  ++s.deferred_count;
  release_locked(s);
  return true;
}

}  // namespace thermovis::transport::detail

// Interposes the C library's munmap for every caller outside the C library itself (which calls
// its internal alias), so Fast DDS's unmapping of a departed writer's pool comes here first.
extern "C" int munmap(void* address, std::size_t length) noexcept {
  if (thermovis::transport::detail::defer_unmap(address, length)) return 0;
  return thermovis::transport::detail::kernel_munmap(address, length);
}
