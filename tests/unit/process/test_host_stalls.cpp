// The host stall probe: a CPU taken from it is recorded as a stall at the right time, and the
// bookkeeping that lays stalls beside frames.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <thread>

#include "thermovis/process/host_stalls.hpp"

namespace tp = thermovis::process;
using namespace std::chrono_literals;

namespace {

std::int64_t realtime_ns() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return t.tv_sec * 1'000'000'000LL + t.tv_nsec;
}

TEST(HostStalls, DuringStallIsOverlapWithAStallOfTheLeastLength) {
  const std::vector<tp::HostStall> stalls{{0, 1'000'000'000, 8.0}, {1, 2'000'000'000, 3.0}};
  // The 8 ms stall spans 1.000-1.008 s.
  EXPECT_TRUE(tp::during_stall(stalls, 990'000'000, 1'001'000'000, 5.0));
  EXPECT_TRUE(tp::during_stall(stalls, 1'007'000'000, 1'020'000'000, 5.0));
  EXPECT_FALSE(tp::during_stall(stalls, 1'009'000'000, 1'020'000'000, 5.0));
  EXPECT_FALSE(tp::during_stall(stalls, 980'000'000, 999'000'000, 5.0));
  // The 3 ms one counts only when shorter stalls are asked for.
  EXPECT_FALSE(tp::during_stall(stalls, 1'999'000'000, 2'001'000'000, 5.0));
  EXPECT_TRUE(tp::during_stall(stalls, 1'999'000'000, 2'001'000'000, 2.0));
  EXPECT_FALSE(tp::during_stall({}, 0, 1, 0.0));
}

TEST(HostStalls, SummaryCountsEveryProbedCpu) {
  const std::vector<tp::HostStall> stalls{{0, 0, 2.5}, {0, 10, 6.0}, {3, 20, 12.0}};
  const tp::HostStallSummary s = tp::summarize(stalls, {0, 3, 5});
  EXPECT_EQ(s.over_5ms, 2u);
  EXPECT_EQ(s.over_10ms, 1u);
  EXPECT_DOUBLE_EQ(s.max_ms, 12.0);
  EXPECT_DOUBLE_EQ(s.total_ms, 20.5);
  ASSERT_EQ(s.over_5ms_by_cpu.size(), 3u);
  EXPECT_EQ(s.over_5ms_by_cpu.at(0), 1u);
  EXPECT_EQ(s.over_5ms_by_cpu.at(3), 1u);
  EXPECT_EQ(s.over_5ms_by_cpu.at(5), 0u);
}

TEST(HostStalls, RejectsAPeriodOfZero) {
  tp::HostStallOptions options;
  options.period = 0us;
  EXPECT_THROW(tp::HostStallProbe probe(options), std::invalid_argument);
}

// A thread above the probe's priority spins 40 ms on one CPU: that CPU's probe thread cannot
// run meanwhile, as on a CPU the host has descheduled, and must record it there and then.
TEST(HostStalls, RecordsACpuTakenByAHigherPriorityOnThatCpuAtItsTime) {
  tp::HostStallProbe probe;
  ASSERT_FALSE(probe.cpus().empty());
  if (probe.scheduling().rfind("fifo", 0) != 0)
    GTEST_SKIP() << "no real-time priority for the probe here: " << probe.scheduling();
  const int cpu = probe.cpus().front();
  std::this_thread::sleep_for(20ms);  // the probe's threads are ticking
  probe.reset();
  std::int64_t begin_ns = 0, end_ns = 0;
  bool prioritised = false;
  std::thread hog([&] {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    pthread_setaffinity_np(pthread_self(), sizeof(one), &one);
    sched_yield();  // onto that CPU before taking it
    sched_param fifo{};
    fifo.sched_priority = 70;
    prioritised = pthread_setschedparam(pthread_self(), SCHED_FIFO, &fifo) == 0;
    begin_ns = realtime_ns();
    const auto until = std::chrono::steady_clock::now() + 40ms;
    while (std::chrono::steady_clock::now() < until) {
    }
    end_ns = realtime_ns();
  });
  hog.join();
  ASSERT_TRUE(prioritised);
  std::this_thread::sleep_for(20ms);  // the stalled thread has woken and recorded it
  const auto stalls = probe.stalls();
  EXPECT_GT(probe.ticks(), 0u);
  const auto it = std::find_if(stalls.begin(), stalls.end(), [&](const tp::HostStall& s) {
    return s.cpu == cpu && s.ms >= 30.0;
  });
  ASSERT_NE(it, stalls.end()) << stalls.size() << " stalls, none of 30 ms on CPU " << cpu;
  // It lies within the spin (the probe's tick may have come up to a period after its start).
  EXPECT_GE(it->start_ns, begin_ns - 2'000'000);
  EXPECT_LE(it->end_ns(), end_ns + 2'000'000);
  EXPECT_TRUE(tp::during_stall(stalls, begin_ns, end_ns, 30.0));
  for (const auto& s : stalls) EXPECT_GE(s.ms, tp::HostStallOptions{}.record_over_ms);
}

}  // namespace
