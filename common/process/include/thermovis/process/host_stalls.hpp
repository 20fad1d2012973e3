#pragma once
// Stalls of the machine itself, told apart from the pipeline's own delays.
//
// On a virtual machine the host deschedules a virtual CPU now and then: nothing of the guest
// runs on it until the host gives it back, whatever its priority, and the guest's scheduler
// does not know (no steal time is reported on this project's machines). A stage on that CPU is
// late by the whole stall, and its latency and the DEADLINE QoS count it as the stage's. The
// probe is a thread on each CPU, at a real-time priority above every stage's, that sleeps to
// the next tick of a fixed period and records each wake-up later than a threshold: the CPU was
// not available to the highest priority of the guest for that long. POSIX (Linux) only.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace thermovis::process {

// One late wake-up of the probe on `cpu`: the CPU was not available from start_ns for ms.
// start_ns is the tick it should have woken at, on the clock of the frames' stamps
// (CLOCK_REALTIME ns), so stalls can be laid beside captures.
struct HostStall {
  int cpu = 0;
  std::int64_t start_ns = 0;
  double ms = 0.0;
  std::int64_t end_ns() const { return start_ns + static_cast<std::int64_t>(ms * 1e6); }
};

struct HostStallOptions {
  std::chrono::microseconds period{1000};  // between two wake-ups of each CPU's thread
  double record_over_ms = 2.0;             // a wake-up this late is recorded as a stall
  int priority = 50;  // SCHED_FIFO (the stages run at 10); not allowed: the normal policy
};

class HostStallProbe {
 public:
  // Starts one thread on each CPU this process may run on.
  explicit HostStallProbe(HostStallOptions options = {});
  ~HostStallProbe();
  HostStallProbe(const HostStallProbe&) = delete;
  HostStallProbe& operator=(const HostStallProbe&) = delete;

  // Forgets the stalls and ticks so far (e.g. after a warm-up).
  void reset();
  std::vector<HostStall> stalls() const;  // in the order recorded
  std::uint64_t ticks() const;            // wake-ups since the last reset, every CPU
  const std::vector<int>& cpus() const { return cpus_; }  // probed, by the system's numbers
  // How the threads run, in words: "fifo 50" or "other (fifo 50 not permitted)".
  const std::string& scheduling() const { return scheduling_; }

 private:
  void run(int cpu);

  HostStallOptions options_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> ticks_{0};
  mutable std::mutex mutex_;
  std::condition_variable started_cv_;
  std::size_t started_ = 0;  // threads that have set their CPU and priority
  bool refused_ = false;     // a thread was not given its real-time priority
  std::vector<HostStall> stalls_;
  std::vector<int> cpus_;
  std::string scheduling_;
  std::vector<std::thread> threads_;
};

// Whether the interval [begin_ns, end_ns] overlaps a stall of at least min_ms.
bool during_stall(const std::vector<HostStall>& stalls, std::int64_t begin_ns, std::int64_t end_ns,
                  double min_ms);

struct HostStallSummary {
  std::uint64_t over_5ms = 0, over_10ms = 0;
  double max_ms = 0.0;
  double total_ms = 0.0;                         // every recorded stall, every CPU
  std::map<int, std::uint64_t> over_5ms_by_cpu;  // every probed CPU, by the system's number
};
HostStallSummary summarize(const std::vector<HostStall>& stalls, const std::vector<int>& cpus);

}  // namespace thermovis::process
