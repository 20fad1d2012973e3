// thermovis-fpga-emu: emulates the FPGA's capture path. It creates the capture ring
// (fpga/ring.hpp) and commits raw captures of the simulated rig (or of a rendered folder) into
// it at the sensors' rate, rendering straight into the ring's slots as the FPGA's DMA writes
// them. thermovis-bridge --source fpga-dma reads them.
//
// The ring carries raw captures, what the sensors deliver; the FPGA's remap stage (fpga/remap)
// works on the rectify side of the pipeline, so it has no place on this path.
#include <CLI/CLI.hpp>
#include <chrono>
#include <csignal>
#include <iostream>
#include <thread>

#include "frame_source.hpp"
#include "thermovis/fpga/ring.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace {
volatile std::sig_atomic_t stop_flag = 0;
void on_signal(int) { stop_flag = 1; }

std::int64_t now_ns() {  // the pipeline's clock (transport/clock.hpp): ns since the Unix epoch
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}
}  // namespace

int main(int argc, char** argv) {
  using namespace thermovis;
  CLI::App app{"thermovis-fpga-emu: writes raw captures into the FPGA capture ring"};
  std::string ring_path = "/dev/shm/thermovis-ring";
  std::string rig_path;
  std::uint32_t slots = 4;
  double rate_hz = 50.0;
  std::int64_t frames = 0;
  bool keep_ring = false;
  bridge::SourceOptions source;
  app.add_option("--ring", ring_path, "ring to create (a file path, or shm:NAME)")
      ->capture_default_str();
  app.add_option("--rig", rig_path, "rig YAML (default: deploy/rigs/paper.yaml)");
  app.add_option("--slots", slots, "ring slots (captures it holds)")
      ->capture_default_str()
      ->check(CLI::Range(2u, 1024u));
  app.add_option("--rate", rate_hz, "captures per second")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--frames", frames, "stop after N captures (0: run until stopped)")
      ->capture_default_str();
  app.add_option("--source", source.kind, "what the emulated sensors see: sim | files")
      ->capture_default_str()
      ->check(CLI::IsMember({"sim", "files"}));
  app.add_option("--scene", source.scene, "sim: scene YAML (default deploy/scenes/paper.yaml)");
  app.add_option("--seed", source.seed, "sim: noise seed")->capture_default_str();
  app.add_option("--prerender", source.prerender,
                 "sim: render N captures at start and cycle through them (0: live; moving "
                 "targets then repeat every N captures)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--dir", source.directory, "files: a `thermovis scene render --out` folder");
  app.add_flag(
      "--no-loop", [&source](std::int64_t) { source.loop = false; },
      "files: stop at the last frame");
  app.add_flag("--preload", source.preload, "files: decode every frame at start");
  app.add_flag("--keep-ring", keep_ring, "leave the ring file in place at exit");
  CLI11_PARSE(app, argc, argv);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    const auto rig = runtime::load_rig_or_default(rig_path);
    auto frame_source = bridge::make_source(source, rig);
    fpga::RingWriter ring(ring_path,
                          fpga::stereo_rig_geometry(frame_source->visible_size(),
                                                    frame_source->infrared_size(), slots));
    std::cerr << "thermovis-fpga-emu: " << frame_source->name() << " -> " << ring_path << " ("
              << slots << " slots)\n";
    using Clock = std::chrono::steady_clock;
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
    std::uint64_t committed = 0, late = 0, bad = 0;
    auto next = Clock::now();
    for (std::int64_t index = 0; stop_flag == 0 && (frames <= 0 || index < frames); ++index) {
      std::this_thread::sleep_until(next);
      const std::int64_t exposure_ns = now_ns();
      const auto views = ring.begin();
      sim::FrameSet images;
      images.images = views;
      try {
        if (!frame_source->fill(index, images)) break;
        ring.commit(static_cast<std::uint64_t>(index), exposure_ns);
        ++committed;
      } catch (const std::exception& e) {
        ++bad;  // not committed: the next capture reuses the slot
        std::cerr << "thermovis-fpga-emu: capture " << index << ": " << e.what() << "\n";
      }
      next += period;
      for (const auto now = Clock::now(); next + period < now; next += period) {
        ++index;  // a sensor does not wait: captures whose time has passed are lost
        ++late;
      }
    }
    std::cerr << "thermovis-fpga-emu: committed " << committed << ", late " << late << ", bad "
              << bad << "\n";
    if (!keep_ring) ring.remove();
  } catch (const std::exception& e) {
    std::cerr << "thermovis-fpga-emu: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
