#include "thermovis/process/host_stalls.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <stdexcept>

namespace thermovis::process {
namespace {

constexpr std::int64_t kNsPerS = 1'000'000'000;

std::int64_t ns_of(const timespec& t) { return t.tv_sec * kNsPerS + t.tv_nsec; }

timespec timespec_of(std::int64_t ns) {
  return {static_cast<time_t>(ns / kNsPerS), static_cast<long>(ns % kNsPerS)};
}

std::int64_t now_ns(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return ns_of(t);
}

// The CPUs this process may run on.
std::vector<int> allowed_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) != 0) return {0};
  std::vector<int> cpus;
  for (int cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if (CPU_ISSET(cpu, &set)) cpus.push_back(cpu);
  return cpus;
}

}  // namespace

HostStallProbe::HostStallProbe(HostStallOptions options) : options_(options) {
  if (options_.period.count() <= 0) throw std::invalid_argument("host stall probe: period <= 0");
  cpus_ = allowed_cpus();
  try {
    for (const int cpu : cpus_) threads_.emplace_back([this, cpu] { run(cpu); });
  } catch (...) {
    stop_ = true;
    for (auto& t : threads_) t.join();
    throw;
  }
  // Each thread says whether it got its real-time priority before the constructor returns.
  std::unique_lock<std::mutex> lock(mutex_);
  started_cv_.wait(lock, [&] { return started_ == threads_.size(); });
  const std::string fifo = "fifo " + std::to_string(options_.priority);
  scheduling_ = refused_ ? "other (" + fifo + " not permitted)" : fifo;
}

HostStallProbe::~HostStallProbe() {
  stop_ = true;
  for (auto& t : threads_) t.join();
}

void HostStallProbe::run(int cpu) {
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  (void)pthread_setaffinity_np(pthread_self(), sizeof(one), &one);
  sched_param fifo{};
  fifo.sched_priority = options_.priority;
  const bool refused = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo) != 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    refused_ = refused_ || refused;
    ++started_;
  }
  started_cv_.notify_all();
  const std::int64_t period_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(options_.period).count();
  const auto record_over_ns = static_cast<std::int64_t>(options_.record_over_ms * 1e6);
  std::int64_t next = now_ns(CLOCK_MONOTONIC) + period_ns;
  while (!stop_) {
    const timespec wake = timespec_of(next);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr) != 0) {
    }
    const std::int64_t woke = now_ns(CLOCK_MONOTONIC);
    const std::int64_t late = woke - next;
    ++ticks_;
    if (late >= record_over_ns) {
      const std::int64_t woke_real = now_ns(CLOCK_REALTIME);
      std::lock_guard<std::mutex> lock(mutex_);
      stalls_.push_back({cpu, woke_real - late, static_cast<double>(late) / 1e6});
    }
    // After a stall the ticks go on from the wake-up: the missed ones are one stall, not many.
    next = late >= period_ns ? woke + period_ns : next + period_ns;
  }
}

void HostStallProbe::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  stalls_.clear();
  ticks_ = 0;
}

std::vector<HostStall> HostStallProbe::stalls() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stalls_;
}

std::uint64_t HostStallProbe::ticks() const { return ticks_; }

bool during_stall(const std::vector<HostStall>& stalls, std::int64_t begin_ns, std::int64_t end_ns,
                  double min_ms) {
  return std::any_of(stalls.begin(), stalls.end(), [&](const HostStall& s) {
    return s.ms >= min_ms && s.start_ns <= end_ns && s.end_ns() >= begin_ns;
  });
}

HostStallSummary summarize(const std::vector<HostStall>& stalls, const std::vector<int>& cpus) {
  HostStallSummary s;
  for (int cpu : cpus) s.over_5ms_by_cpu[cpu] = 0;
  for (const HostStall& stall : stalls) {
    s.total_ms += stall.ms;
    s.max_ms = std::max(s.max_ms, stall.ms);
    if (stall.ms < 5.0) continue;
    ++s.over_5ms;
    if (stall.ms >= 10.0) ++s.over_10ms;
    ++s.over_5ms_by_cpu[stall.cpu];
  }
  return s;
}

}  // namespace thermovis::process
