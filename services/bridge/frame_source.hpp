#pragma once
// Where the bridge's raw frames come from. A source fills the four raw images of one capture
// (visible left/right CV_8UC3, infrared left/right CV_16UC1) into buffers the bridge provides
// (views of loaned DDS samples, so a frame is written once, in place).
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core/types.hpp>
#include <optional>
#include <string>

#include "thermovis/camera/rig.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::bridge {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual std::string name() const = 0;
  virtual cv::Size visible_size() const = 0;
  virtual cv::Size infrared_size() const = 0;
  // Fills `out` (images already of the right size and type) with capture number `index`.
  // Returns false at the end of the stream. Throws std::runtime_error for a bad input frame
  // (the bridge reports it and goes on with the next).
  virtual bool fill(std::int64_t index, sim::FrameSet& out) = 0;

  // True when fill() itself waits for the next capture (a device that runs at its own rate):
  // the bridge then does not pace it with --rate.
  virtual bool self_paced() const { return false; }
  // Start of exposure of the capture the last successful fill() delivered, ns on the pipeline's
  // clock (transport/clock.hpp), when the source knows it; else the bridge stamps the capture.
  virtual std::optional<std::int64_t> capture_time_ns() const { return std::nullopt; }
  // Captures the source itself lost before the bridge could take them (e.g. a ring overrun).
  virtual std::uint64_t skipped() const { return 0; }
  // While the source still prepares its captures in the background and costs more than in its
  // steady state (the simulated rig rendering live what it has not prerendered yet): what it
  // has done, e.g. "37 of 100 captures prerendered". Empty once it runs as it will.
  virtual std::string preparing() const { return {}; }
};

struct SourceOptions {
  std::string kind = "sim";  // sim | files | v4l2 | fpga-dma
  std::string scene;         // sim: scene YAML (default deploy/scenes/paper.yaml)
  std::uint64_t seed = 1;    // sim
  // sim: cycle through this many captures (0 = render every capture live), rendered once in the
  // background (until one is ready it is rendered live). Each capture then costs a copy instead
  // of a render, but moving targets repeat every `prerender` captures, and the captures are held
  // in memory (about 15.6 MB each for the paper's rig).
  std::int64_t prerender = 0;
  // sim: the rig file the rig was loaded from (keys the static scene cache; empty: no cache)
  // and the cache folder: "auto" ($XDG_CACHE_HOME/thermovis or ~/.cache/thermovis), a folder,
  // or "none".
  std::filesystem::path rig_file;
  std::string sim_cache = "auto";
  std::string directory;  // files: a folder written by `thermovis scene render --out`
  bool loop = true;       // files: start again at the end
  bool preload = false;   // files: decode every frame at start (memory: ~15.6 MB per frame)
  std::string devices;    // v4l2: four device paths, comma-separated (VL,VR,IL,IR)
  std::string ring;       // fpga-dma: the capture ring's path (fpga/ring.hpp)
  std::chrono::milliseconds ring_timeout{500};  // fpga-dma: a fill waits this long at most
};

inline constexpr const char* kSourceKinds = "sim, files, v4l2, fpga-dma";

// Throws std::runtime_error naming the missing file / device / ring, the empty folder, or the
// bad option.
std::unique_ptr<FrameSource> make_source(const SourceOptions& options, const camera::Rig& rig);

}  // namespace thermovis::bridge
