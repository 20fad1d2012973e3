#include "frame_source.hpp"

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::bridge {
namespace {

class SimSource final : public FrameSource {
 public:
  SimSource(const camera::Rig& rig, const std::string& scene_path, std::uint64_t seed)
      : sim_(rig,
             runtime::load_scene(scene_path.empty() ? runtime::shipped_file("scenes/paper.yaml")
                                                    : std::filesystem::path(scene_path)),
             seed) {}
  std::string name() const override { return "sim"; }
  cv::Size visible_size() const override {
    return sim_.camera(sim::Slot::visible_left).model->image_size();
  }
  cv::Size infrared_size() const override {
    return sim_.camera(sim::Slot::infrared_left).model->image_size();
  }
  bool fill(std::int64_t index, sim::FrameSet& out) override {
    sim_.render(index, out);
    return true;
  }

 private:
  sim::SimulatedRig sim_;
};

// Four cameras through OpenCV's V4L2 backend: visible ones deliver BGR, infrared ones 16-bit
// raw (CAP_PROP_CONVERT_RGB off) or 8-bit grey, widened to 16 bits.
class V4l2Source final : public FrameSource {
 public:
  V4l2Source(const camera::Rig& rig, const std::string& devices) : rig_(rig) {
    std::vector<std::string> paths;
    std::stringstream list(devices);
    for (std::string item; std::getline(list, item, ',');) paths.push_back(item);
    if (paths.size() != 4) {
      throw std::runtime_error(
          "v4l2 source: --devices needs four devices (visible left, visible "
          "right, infrared left, infrared right), got '" +
          devices + "'");
    }
    for (int i = 0; i < 4; ++i) {
      captures_[i].open(paths[i], cv::CAP_V4L2);
      if (!captures_[i].isOpened())
        throw std::runtime_error("v4l2 source: cannot open " + paths[i]);
      if (i >= 2) captures_[i].set(cv::CAP_PROP_CONVERT_RGB, 0);
      paths_[i] = paths[i];
    }
  }
  std::string name() const override { return "v4l2"; }
  cv::Size visible_size() const override {
    return rig_.camera(rig_.visible.left).model->image_size();
  }
  cv::Size infrared_size() const override {
    return rig_.camera(rig_.infrared.left).model->image_size();
  }
  bool fill(std::int64_t /*index*/, sim::FrameSet& out) override {
    for (int i = 0; i < 4; ++i) {
      cv::Mat grabbed;
      if (!captures_[i].read(grabbed) || grabbed.empty()) return false;
      cv::Mat& target = out.images[i];
      if (grabbed.size() != target.size()) {
        throw std::runtime_error("v4l2 source: " + paths_[i] + " delivered " +
                                 std::to_string(grabbed.cols) + "x" + std::to_string(grabbed.rows) +
                                 ", the rig says " + std::to_string(target.cols) + "x" +
                                 std::to_string(target.rows));
      }
      if (target.type() == CV_8UC3) {
        if (grabbed.channels() == 1)
          cv::cvtColor(grabbed, target, cv::COLOR_GRAY2BGR);
        else
          grabbed.copyTo(target);
      } else if (grabbed.depth() == CV_16U) {
        grabbed.reshape(1).copyTo(target);
      } else {
        cv::Mat grey = grabbed;
        if (grey.channels() == 3) cv::cvtColor(grabbed, grey, cv::COLOR_BGR2GRAY);
        grey.convertTo(target, CV_16U, 64.0);  // 8-bit into the top of 14 bits
      }
    }
    return true;
  }

 private:
  camera::Rig rig_;
  cv::VideoCapture captures_[4];
  std::string paths_[4];
};

}  // namespace

std::unique_ptr<FrameSource> make_source(const SourceOptions& options, const camera::Rig& rig) {
  if (options.kind == "sim") return std::make_unique<SimSource>(rig, options.scene, options.seed);
  if (options.kind == "v4l2") return std::make_unique<V4l2Source>(rig, options.devices);
  throw std::runtime_error("unknown source '" + options.kind + "' (known: sim, v4l2)");
}

}  // namespace thermovis::bridge
