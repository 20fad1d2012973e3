// Latency of a frame from one process to another through Fast DDS data-sharing, loaned path
// vs copied path, in one run:
//   loaned: the writer fills a sample loaned from its shared pool and publishes it; the reader
//           takes a loan pointing into that pool (no copy anywhere);
//   copied: the writer publishes a frame it owns (copied into the pool) and the reader copies
//           the sample out of its loan into its own frame (what code without loans does).
// The publisher is this executable started again as a child (--publisher ...), on a private
// domain with the loopback profile; it stamps capture_time_ns just before publishing and the
// reader measures now - stamp after its take (and copy). Latency figures: p50/p99/max counters,
// iteration time = per-frame latency (manual time). Frames at 50 Hz, 200 per case.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "thermovis/metrics/percentile.hpp"
#include "thermovis/test/child_process.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

namespace tt = thermovis::transport;
using namespace std::chrono_literals;

constexpr const char* kTopic = "thermovis/bench/frames";
constexpr int kFrames = 200;   // measured frames per case
constexpr int kWarmUp = 10;    // frames before measuring (first-touch page faults)
constexpr int kPeriodMs = 20;  // 50 Hz

enum class Path { loaned, copied };

tt::ParticipantConfig loopback(int domain, const std::string& name) {
  return {domain, {}, tt::kLoopbackProfile, name};
}

// Frames are far too large for the stack: always on the heap.
template <class Frame>
std::unique_ptr<Frame> make_frame() {
  return std::make_unique<Frame>();
}

template <class Frame>
int publish(int domain, Path path, int count) {
  tt::Participant participant(loopback(domain, "transport_bench publisher"));
  tt::Writer<Frame> writer(participant, kTopic, tt::frame_topic_qos(1s));
  if (!writer.wait_for_readers(1, 30s)) return 3;
  auto own = make_frame<Frame>();  // the copied path's frame, filled once
  std::memset(own->left().data(), 0x5a, sizeof(own->left()));
  std::memset(own->right().data(), 0xa5, sizeof(own->right()));
  auto next = std::chrono::steady_clock::now();
  for (int i = 0; i < count && writer.counters().matched > 0; ++i) {
    std::this_thread::sleep_until(next += std::chrono::milliseconds(kPeriodMs));
    const auto seq = static_cast<std::uint64_t>(i + 1);
    if (path == Path::loaned) {
      auto frame = writer.loan();
      frame->seq(seq);
      tt::clear_stamps(frame->stamps());
      frame->capture_time_ns(tt::now_ns());
      writer.publish(std::move(frame));
    } else {
      own->seq(seq);
      tt::clear_stamps(own->stamps());
      own->capture_time_ns(tt::now_ns());
      writer.write(*own);
    }
  }
  const auto give_up = std::chrono::steady_clock::now() + 30s;
  while (writer.counters().matched > 0 && std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(10ms);
  }
  return 0;
}

// Receives frames for the benchmark iterations on `domain`; reader and participant are gone
// when it returns.
template <class Frame>
void measure(benchmark::State& state, int domain, Path path) {
  tt::Participant participant(loopback(domain, "transport_bench subscriber"));
  tt::Reader<Frame> reader(participant, kTopic, tt::frame_topic_qos(1s));
  if (!reader.wait_for_writers(1, 30s)) {
    state.SkipWithError("publisher did not match");
    return;
  }
  auto local = make_frame<Frame>();  // the copied path's destination
  std::deque<double> pending;        // latencies (s) not yet reported
  std::vector<double> latencies_ms;
  std::uint64_t last_seq = 0, lost = 0;
  auto receive = [&]() {
    while (pending.empty()) {
      if (!reader.wait_for_data(2s)) return false;
      auto samples = reader.take();
      for (std::size_t i = 0; i < samples.size(); ++i) {
        const Frame& frame = samples[i];
        if (path == Path::copied) *local = frame;
        const double latency_s = static_cast<double>(tt::now_ns() - frame.capture_time_ns()) * 1e-9;
        if (last_seq != 0 && frame.seq() > last_seq + 1) lost += frame.seq() - last_seq - 1;
        last_seq = frame.seq();
        if (frame.seq() > kWarmUp) pending.push_back(latency_s);
      }
    }
    return true;
  };
  for (auto _ : state) {
    if (!receive()) {
      state.SkipWithError("no frame within 2 s");
      break;
    }
    state.SetIterationTime(pending.front());
    latencies_ms.push_back(pending.front() * 1e3);
    pending.pop_front();
  }
  state.counters["p50_ms"] = thermovis::metrics::percentile(latencies_ms, 50);
  state.counters["p99_ms"] = thermovis::metrics::percentile(latencies_ms, 99);
  state.counters["max_ms"] = thermovis::metrics::percentile(latencies_ms, 100);
  state.counters["lost"] = static_cast<double>(lost);
  state.counters["MB"] = static_cast<double>(sizeof(Frame)) / 1e6;
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(sizeof(Frame)));
}

template <class Frame>
void BM_FrameLatency(benchmark::State& state, const char* type, Path path) {
  static int run = 0;
  const int domain = 100 + static_cast<int>((::getpid() + run++) % 100);
  const auto log = std::filesystem::temp_directory_path() /
                   ("transport_bench_publisher_" + std::to_string(domain) + ".log");
  thermovis::test::ChildProcess publisher(
      {"/proc/self/exe", "--publisher", type, path == Path::loaned ? "loaned" : "copied",
       std::to_string(domain), std::to_string(kFrames + kWarmUp + 20)},
      log);
  measure<Frame>(state, domain, path);
  // The publisher leaves once this reader is gone; a clean exit removes its shared-memory pool
  // (killing it would leave the pool in /dev/shm).
  if (publisher.wait(30s) != 0) {
    const std::string error = "publisher failed: " + publisher.log();
    state.SkipWithError(error.c_str());
    return;
  }
  std::filesystem::remove(log);
}

// Infrared stereo frame: 2 x 1024 x 768 x 16 bit = 3.1 MB; visible: 2 x 1920 x 1080 x 3 = 12.4 MB.
void BM_InfraredFrameLatency(benchmark::State& state, Path path) {
  BM_FrameLatency<thermovis::InfraredStereoFrame>(state, "infrared", path);
}
void BM_VisibleFrameLatency(benchmark::State& state, Path path) {
  BM_FrameLatency<thermovis::VisibleStereoFrame>(state, "visible", path);
}

BENCHMARK_CAPTURE(BM_InfraredFrameLatency, loaned, Path::loaned)
    ->Iterations(kFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_InfraredFrameLatency, copied, Path::copied)
    ->Iterations(kFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_VisibleFrameLatency, loaned, Path::loaned)
    ->Iterations(kFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_VisibleFrameLatency, copied, Path::copied)
    ->Iterations(kFrames)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  // Child mode: transport_bench --publisher <infrared|visible> <loaned|copied> <domain> <count>
  if (argc == 6 && std::string(argv[1]) == "--publisher") {
    try {
      const std::string type = argv[2];
      const Path path = std::string(argv[3]) == "loaned" ? Path::loaned : Path::copied;
      const int domain = std::stoi(argv[4]);
      const int count = std::stoi(argv[5]);
      return type == "visible" ? publish<thermovis::VisibleStereoFrame>(domain, path, count)
                               : publish<thermovis::InfraredStereoFrame>(domain, path, count);
    } catch (const std::exception& e) {
      std::cerr << "transport_bench publisher: " << e.what() << "\n";
      return 2;
    }
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
