#pragma once
// thermovis-detect: rectified infrared frames (the pipeline grid) -> detections of the left eye on
// thermovis/detections (pipeline::DetectStage: warm blobs, optionally HOG on the fused frame,
// merged). The grid comes from thermovis/geometry. Only the newest frame is processed; older
// ones waiting are dropped and counted. Other DDS applications may publish on the detections
// topic too (an external detector): the matcher takes any DetectionArray whose frame it still
// has.
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "thermovis/frames.h"
#include "thermovis/node/frame_join.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/node/health.hpp"
#include "thermovis/perception.h"
#include "thermovis/pipeline/detect_stage.hpp"
#include "thermovis/transport/frames.hpp"
#include "thermovis/transport/writer.hpp"

namespace thermovis::detect_service {

struct DetectConfig {
  pipeline::DetectOptions detect;
  // Extra time spent per frame, for overload tests (a stage that cannot keep up).
  std::chrono::milliseconds debug_delay{0};
  std::chrono::nanoseconds deadline{20'000'000};
};

struct DetectStats {
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;  // frames superseded before they were processed
  std::uint64_t bad = 0;      // frames rejected (header, size, geometry, out of order)
  std::uint64_t detections = 0;
  std::uint64_t repeated = 0;     // frames received again, skipped
  std::uint64_t no_geometry = 0;  // frames that came before thermovis/geometry
};

class DetectNode {
 public:
  DetectNode(transport::Participant& participant, const DetectConfig& config,
             const std::string& service_name);
  void run();  // until node::stop_requested()
  DetectStats stats() const;

 private:
  // The detections of one frame (published by run() once the frame proved intact).
  DetectionArray detect(const GridStereoFrame& infrared);
  void take_fused(std::chrono::milliseconds wait, std::uint64_t from_seq);

  DetectConfig config_;
  node::StageOnGeometry<pipeline::DetectStage, pipeline::DetectOptions> stage_;
  transport::FrameReader<GridStereoFrame> infrared_in_;
  std::unique_ptr<transport::FrameReader<GridStereoFrame>> fused_in_;  // with --hog only
  transport::Writer<DetectionArray> out_;
  node::HealthReporter health_;
  DetectStats stats_;
  node::FrameSequence sequence_;    // of the rectified infrared frames taken
  node::SeqBuffer<cv::Mat> fused_;  // left fused images (copies), --hog only
};

}  // namespace thermovis::detect_service
