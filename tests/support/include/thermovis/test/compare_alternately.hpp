#pragma once
// A Google Benchmark body that times two implementations of the same work alternately in one
// loop, so that both see the same machine load (the reference machine is shared), and reports
// ours_ms, <theirs>_ms and <theirs>_over_ours = time(theirs) / time(ours) (> 1: ours faster).
// Header-only: for benchmark executables (they link benchmark::benchmark).
#include <benchmark/benchmark.h>

#include <chrono>
#include <string>

namespace thermovis::test {

template <typename Ours, typename Theirs>
void compare_alternately(benchmark::State& state, const std::string& theirs_name, Ours ours,
                         Theirs theirs) {
  double ours_s = 0.0, theirs_s = 0.0;
  using Clock = std::chrono::steady_clock;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    ours();
    const auto t1 = Clock::now();
    theirs();
    const auto t2 = Clock::now();
    ours_s += std::chrono::duration<double>(t1 - t0).count();
    theirs_s += std::chrono::duration<double>(t2 - t1).count();
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["ours_ms"] = 1e3 * ours_s / n;
  state.counters[theirs_name + "_ms"] = 1e3 * theirs_s / n;
  state.counters[theirs_name + "_over_ours"] = ours_s > 0.0 ? theirs_s / ours_s : 0.0;
}

}  // namespace thermovis::test
