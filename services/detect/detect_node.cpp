#include "detect_node.hpp"

#include <cmath>
#include <stdexcept>
#include <thread>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::detect_service {
namespace {

// How long a frame's detection waits for the fused image of the same capture (--hog).
constexpr std::chrono::milliseconds kFusedWait{50};

// This node holds at most one frame of each topic while it works on it.
transport::TopicQos frame_reader_qos(std::chrono::nanoseconds deadline) {
  return transport::frame_topic_qos(deadline, 2, 2);
}

std::string clipped_label(const std::string& label) { return label.substr(0, MAX_LABEL_LENGTH); }

}  // namespace

DetectNode::DetectNode(transport::Participant& participant, const DetectConfig& config,
                       const std::string& service_name)
    : config_(config),
      stage_(participant, config.detect),
      infrared_in_(participant, transport::topics::kRectifiedInfrared,
                   frame_reader_qos(config.deadline), node::count_bad_input(stats_.bad, health_)),
      out_(participant, transport::topics::kDetections, transport::event_topic_qos()),
      health_(participant, service_name,
              [this] {
                std::vector<transport::TopicCountersSnapshot> counters{
                    infrared_in_.counters(), out_.counters(), stage_.counters()};
                if (fused_in_) counters.push_back(fused_in_->counters());
                return counters;
              }),
      sequence_(service_name, "rectified infrared frame"),
      fused_(2) {
  if (config_.detect.hog) {
    fused_in_ = std::make_unique<transport::FrameReader<GridStereoFrame>>(
        participant, transport::topics::kFused, frame_reader_qos(config.deadline),
        node::count_bad_input(stats_.bad, health_));
  }
  health_.set_state(HEALTH_STARTING, "no grid geometry yet (thermovis/geometry)");
}

DetectStats DetectNode::stats() const {
  DetectStats s = stats_;
  s.repeated = sequence_.repeated();
  s.bad += sequence_.stale();
  return s;
}

void DetectNode::run() {
  node::wait_for_geometry(stage_, health_, "rectified infrared frames", node::stop_requested);
  while (!node::stop_requested()) {
    health_.tick();
    const bool have_stage = stage_.refresh(health_);
    if (!infrared_in_.wait_for_data(std::chrono::milliseconds(100))) continue;
    auto frames = infrared_in_.take();
    if (frames.empty()) continue;
    stats_.dropped += frames.size() - 1;  // only the newest is worth the time
    const std::size_t newest = frames.size() - 1;
    if (!have_stage) {
      ++stats_.no_geometry;
      continue;
    }
    if (!sequence_.admit(frames[newest].seq(), frames[newest].capture_time_ns(), health_)) {
      continue;
    }
    if (sequence_.last_verdict() == node::FrameOrder::Verdict::restarted) fused_.clear();
    try {
      const DetectionArray out = detect(frames[newest]);
      if (!frames.still_valid(newest)) {
        // The writer reused the sample while it was read (this stage fell a pool's length
        // behind): the detections may mix two frames, so they are not published. A drop, not
        // bad input: nothing was wrong with the frame.
        ++stats_.dropped;
        continue;
      }
      // The overload tests' slow detector: the extra time comes after the frame was read (as a
      // detector that copied its input), so the frame is not overwritten meanwhile; a 150 ms
      // wait while reading would outlast the pool at 50 Hz on a fast machine and no frame would
      // ever be detected, a test of the machine's speed rather than of the pipeline.
      if (config_.debug_delay.count() > 0) std::this_thread::sleep_for(config_.debug_delay);
      out_.write(out);
      stats_.detections += out.detections().size();
      ++stats_.processed;
      health_.frame_processed();
    } catch (const std::exception& e) {
      ++stats_.bad;
      health_.bad_input(e.what());
    }
  }
  health_.set_state(HEALTH_STOPPING, "processed " + std::to_string(stats_.processed));
}

void DetectNode::take_fused(std::chrono::milliseconds wait, std::uint64_t from_seq) {
  if (wait.count() > 0) fused_in_->wait_for_data(wait);
  auto fused = fused_in_->take();
  for (std::size_t i = 0; i < fused.size(); ++i) {
    // Only captures not yet passed are worth the copy.
    if (fused[i].seq() < from_seq) continue;
    fused_.push(
        fused[i].seq(),
        node::view(fused[i], node::Eye::left, stage_.geometry().grid_size(), stage_.id()).clone());
  }
}

DetectionArray DetectNode::detect(const GridStereoFrame& infrared) {
  const std::int64_t start_ns = transport::now_ns();
  const cv::Mat left =
      node::view(infrared, node::Eye::left, stage_.geometry().image_size(pipeline::Band::infrared),
                 stage_.id());
  cv::Mat fused;
  if (fused_in_) {
    // rectify-fuse publishes the fused frame of a capture after its rectified pairs (once the
    // fusion is done): wait for it a while, never for a capture already passed.
    const std::uint64_t seq = infrared.seq();
    const cv::Mat* found = node::join<cv::Mat>(
        fused_, seq, kFusedWait,
        [this, seq](std::chrono::milliseconds wait) { take_fused(wait, seq); },
        node::stop_requested);
    if (found != nullptr) fused = *found;
    fused_.drop_through(seq);
  }
  std::vector<detect::Detection> found;
  try {
    found = stage_.stage().detect(left, fused);
  } catch (const std::invalid_argument& e) {
    throw node::FrameError("rectified infrared frame " + std::to_string(infrared.seq()) + ": " +
                           e.what());
  }
  // The stage returns them strongest first: the strongest fit the message.
  if (found.size() > MAX_TARGETS) found.resize(MAX_TARGETS);

  DetectionArray out;
  out.frame_seq(infrared.seq());
  out.capture_time_ns(infrared.capture_time_ns());
  std::uint32_t id = 0;
  for (const auto& d : found) {
    Detection detection;
    detection.target_id(id++);
    detection.label(clipped_label(d.cls));
    // Scores are margins (warm blobs: robust sigmas over the threshold; HOG: SVM margin);
    // squashed into 0..1 for consumers that expect a confidence.
    detection.score(static_cast<float>(d.score / (1.0 + std::abs(d.score))));
    detection.box(node::to_box(d.box));
    out.detections().push_back(detection);
  }
  out.stamps(infrared.stamps());
  transport::append_stamp(out.stamps(), STAGE_DETECT, start_ns, transport::now_ns());
  return out;
}

}  // namespace thermovis::detect_service
