#pragma once
// thermovis-detect: rectified infrared frames (MONO8 on the pipeline grid) -> detections of the
// left eye on thermovis/detections. Warm blobs (people warmer than their background) on the
// infrared band, optionally OpenCV's HOG people detector on the fused frame, merged by
// non-maximum suppression. Only the newest frame is processed; older ones waiting are dropped
// and counted. Other DDS applications may publish on the detections topic too (an external
// detector): the matcher takes any DetectionArray whose frame it still has.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "thermovis/detect/detectors.hpp"
#include "thermovis/frames.h"
#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/node/pipeline_grid.hpp"
#include "thermovis/perception.h"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::detect_service {

struct DetectConfig {
  node::GridOptions grid;
  detect::WarmBlobOptions blobs;
  bool hog = false;  // also run the HOG people detector on the fused left image
  detect::HogOptions hog_options{0.5, 0.0, 1.05};
  double nms_iou = 0.3;
  // Extra time spent per frame, for overload tests (a stage that cannot keep up).
  std::chrono::milliseconds debug_delay{0};
  std::chrono::nanoseconds deadline{20'000'000};
};

struct DetectStats {
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;  // frames superseded before they were processed
  std::uint64_t bad = 0;      // frames rejected (header, size, grid mismatch)
  std::uint64_t detections = 0;
  std::uint64_t repeated = 0;  // frames received again or out of order, skipped
};

class DetectNode {
 public:
  DetectNode(transport::Participant& participant, const camera::Rig& rig,
             const DetectConfig& config, const std::string& service_name);
  void run();  // until node::stop_requested()
  DetectStats stats() const { return stats_; }

 private:
  // The detections of one frame (published by run() once the frame proved intact).
  DetectionArray detect(const GridStereoFrame& infrared);
  cv::Mat fused_left_for(std::uint64_t seq);

  DetectConfig config_;
  camera::RectifiedCamera grid_;
  transport::Reader<GridStereoFrame> infrared_in_;
  std::unique_ptr<transport::Reader<GridStereoFrame>> fused_in_;  // with --hog only
  transport::Writer<DetectionArray> out_;
  node::HealthReporter health_;
  DetectStats stats_;
  node::FrameOrder order_;  // of the rectified infrared frames taken
};

}  // namespace thermovis::detect_service
