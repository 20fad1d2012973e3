// The sources that need OpenCV's image codecs and video I/O (files, v4l2), built as a module of
// their own (media_sources.hpp says why).
#include "media_sources.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace thermovis::bridge {
namespace {

// Playback of a folder written by `thermovis scene render --out DIR`: one subfolder per frame
// named by its index (000000, 000001, ...), each holding visible_left.png, visible_right.png
// (8-bit BGR), infrared_left.png, infrared_right.png (16-bit grey, raw counts) and truth.json.
// Frames play in index order; capture k shows frame k % count (so captures the bridge skips
// when it falls behind are skipped in the playback too, and a capture's seq maps to its frame).
// Decoding the PNGs of one capture takes about 200 ms of CPU at the paper's resolution, so
// playback decoding live runs at a few captures per second; with `preload` every frame is
// decoded at start and a capture costs a copy.
class FilesSource final : public FrameSource {
 public:
  FilesSource(const camera::Rig& rig, const std::string& directory, bool loop, bool preload)
      : directory_(directory), loop_(loop) {
    namespace fs = std::filesystem;
    if (directory.empty())
      throw std::runtime_error(
          "files source: --dir is required (a `thermovis scene render` folder)");
    std::error_code error;
    if (!fs::is_directory(directory_, error))
      throw std::runtime_error("files source: " + directory + " is not a folder");
    std::vector<std::pair<std::int64_t, fs::path>> frames;
    for (const auto& entry : fs::directory_iterator(directory_)) {
      const std::string stem = entry.path().filename().string();
      if (!entry.is_directory() || stem.empty() ||
          !std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; }))
        continue;
      frames.emplace_back(std::stoll(stem), entry.path());
    }
    if (frames.empty()) {
      throw std::runtime_error("files source: " + directory +
                               " holds no frames (expected numbered subfolders such as 000000/ "
                               "with visible_left.png ... infrared_right.png, as `thermovis scene "
                               "render --out` writes them)");
    }
    std::sort(frames.begin(), frames.end());
    for (auto& frame : frames) frames_.push_back(std::move(frame.second));
    sizes_[0] = sizes_[1] = rig.camera(rig.visible.left).model->image_size();
    sizes_[2] = sizes_[3] = rig.camera(rig.infrared.left).model->image_size();
    if (preload) {
      // Decoded once; a bad frame keeps its error, reported each time the frame comes round.
      decoded_.resize(frames_.size());
      errors_.resize(frames_.size());
      for (std::size_t k = 0; k < frames_.size(); ++k) {
        for (int i = 0; i < sim::kSlotCount; ++i)
          decoded_[k].images[static_cast<std::size_t>(i)].create(
              sizes_[static_cast<std::size_t>(i)], i < 2 ? CV_8UC3 : CV_16UC1);
        try {
          decode(frames_[k], decoded_[k]);
        } catch (const std::runtime_error& e) {
          errors_[k] = e.what();
          decoded_[k] = {};
        }
      }
    }
  }
  std::string name() const override {
    return "files (" + std::to_string(frames_.size()) + " frames from " + directory_.string() +
           (decoded_.empty() ? "" : ", preloaded") + (loop_ ? ", looping)" : ")");
  }
  cv::Size visible_size() const override { return sizes_[0]; }
  cv::Size infrared_size() const override { return sizes_[2]; }
  bool fill(std::int64_t index, sim::FrameSet& out) override {
    const auto count = static_cast<std::int64_t>(frames_.size());
    if (!loop_ && index >= count) return false;
    const auto k = static_cast<std::size_t>(index % count);
    if (decoded_.empty()) {
      decode(frames_[k], out);
    } else {
      if (!errors_[k].empty()) throw std::runtime_error(errors_[k]);
      for (std::size_t i = 0; i < out.images.size(); ++i)
        decoded_[k].images[i].copyTo(out.images[i]);
    }
    return true;
  }

 private:
  void decode(const std::filesystem::path& frame, sim::FrameSet& out) const {
    for (int i = 0; i < sim::kSlotCount; ++i) {
      const std::filesystem::path file =
          frame / (std::string(sim::to_string(static_cast<sim::Slot>(i))) + ".png");
      load(file, i, out.images[static_cast<std::size_t>(i)]);
    }
  }

  static std::string type_text(int type) {
    return std::to_string(CV_ELEM_SIZE1(type) * 8) + "-bit " + std::to_string(CV_MAT_CN(type)) +
           "-channel";
  }

  // Decodes `file` into `target` (a view of the outgoing frame, already of the rig's size and
  // type); std::runtime_error naming the file for anything that does not fit.
  void load(const std::filesystem::path& file, int slot, cv::Mat& target) const {
    std::error_code error;
    if (!std::filesystem::is_regular_file(file, error))
      throw std::runtime_error("files source: missing " + file.string());
    const cv::Mat image = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (image.empty())
      throw std::runtime_error("files source: cannot decode " + file.string() +
                               " (corrupt or not an image)");
    const bool visible = slot < 2;
    const int expected_type = visible ? CV_8UC3 : CV_16UC1;
    if (image.type() != expected_type) {
      throw std::runtime_error("files source: " + file.string() + " is " + type_text(image.type()) +
                               ", expected " + type_text(expected_type) +
                               (visible ? " (BGR colour)" : " (raw infrared counts)"));
    }
    const cv::Size expected = sizes_[static_cast<std::size_t>(slot)];
    if (image.size() != expected) {
      throw std::runtime_error(
          "files source: " + file.string() + " is " + std::to_string(image.cols) + "x" +
          std::to_string(image.rows) + ", the rig's " + (visible ? "visible" : "infrared") +
          " camera is " + std::to_string(expected.width) + "x" + std::to_string(expected.height));
    }
    image.copyTo(target);
  }

  std::filesystem::path directory_;
  bool loop_;
  std::vector<std::filesystem::path> frames_;
  std::array<cv::Size, sim::kSlotCount> sizes_;
  std::vector<sim::FrameSet> decoded_;  // --preload: every frame, decoded at start
  std::vector<std::string> errors_;     // --preload: why a frame could not be decoded
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
}  // namespace thermovis::bridge

extern "C" thermovis::bridge::FrameSource* thermovis_bridge_media_source(
    const thermovis::bridge::SourceOptions& options, const thermovis::camera::Rig& rig) {
  using namespace thermovis::bridge;
  if (options.kind == "files")
    return new FilesSource(rig, options.directory, options.loop, options.preload);
  if (options.kind == "v4l2") return new V4l2Source(rig, options.devices);
  throw std::runtime_error("media sources: unknown source '" + options.kind + "'");
}
