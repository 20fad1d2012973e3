#pragma once
// Where the bridge's raw frames come from. A source fills the four raw images of one capture
// (visible left/right CV_8UC3, infrared left/right CV_16UC1) into buffers the bridge provides
// (views of loaned DDS samples, so a frame is written once, in place).
#include <cstdint>
#include <memory>
#include <opencv2/core/types.hpp>
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
};

struct SourceOptions {
  std::string kind = "sim";  // sim | files | v4l2
  std::string scene;         // sim: scene YAML (default deploy/scenes/paper.yaml)
  std::uint64_t seed = 1;    // sim
  std::string directory;     // files: a folder written by `thermovis scene render`
  bool loop = true;          // files: start again at the end
  std::string devices;       // v4l2: four device paths, comma-separated (VL,VR,IL,IR)
};

// Throws std::runtime_error naming the missing file / device or bad option.
std::unique_ptr<FrameSource> make_source(const SourceOptions& options, const camera::Rig& rig);

}  // namespace thermovis::bridge
