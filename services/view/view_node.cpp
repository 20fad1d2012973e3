#include "view_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::view {
namespace {

using display::View;

// Frames kept per band: range results arrive a few frames after their fused frame (detection,
// matching and ranging lie between), and a loaded machine stretches that.
constexpr std::size_t kRing = 16;
constexpr std::size_t kKeptResults = 32;

// Readers of the pipeline's frames: an observer's (the viewer is not in the chain whose rate the
// services watch, and takes what it can).
transport::TopicQos frame_reader_qos() {
  return transport::observer_qos(transport::frame_topic_qos());
}

// The display topic is written at the composition rate, far below 50 Hz: no DEADLINE either.
transport::TopicQos display_writer_qos() {
  return transport::frame_topic_qos(std::chrono::nanoseconds(0), 2, 2);
}

// Copies the newest left image of `reader`'s samples into `ring` (reusing the oldest buffer),
// when `wanted`; the loans go back when `samples` goes out of scope. False when the writer reused
// the sample's slot during the copy (the copy is then dropped).
bool copy_newest(transport::FrameSamples<GridStereoFrame>& samples,
                 std::deque<ViewNode::Image>& ring) {
  const std::size_t i = samples.size() - 1;
  const GridStereoFrame& frame = samples[i];
  const cv::Mat left = node::view(frame, node::Eye::left);
  ViewNode::Image image;
  if (ring.size() >= kRing) {
    image = std::move(ring.front());
    ring.pop_front();
  }
  image.seq = frame.seq();
  image.capture_time_ns = frame.capture_time_ns();
  left.copyTo(image.left);  // reuses the buffer when the size is unchanged
  if (!samples.still_valid(i)) return false;
  ring.push_back(std::move(image));
  return true;
}

}  // namespace

ViewNode::ViewNode(transport::Participant& participant, ViewHub& hub, const ViewConfig& config,
                   const std::string& service_name)
    : hub_(hub),
      config_(config),
      participant_(participant),
      fused_in_(participant, transport::topics::kFused, frame_reader_qos(),
                node::count_bad_input(stats_.bad, health_)),
      detections_in_(participant, transport::topics::kDetections, transport::event_topic_qos()),
      ranges_in_(participant, transport::topics::kRanges, transport::event_topic_qos()),
      obstacles_in_(participant, transport::topics::kObstacles, transport::event_topic_qos()),
      timing_in_(participant, transport::topics::kTiming, transport::event_topic_qos(64)),
      health_in_(participant, transport::topics::kHealth, transport::state_topic_qos()),
      display_out_(participant, transport::topics::kDisplay, display_writer_qos()),
      health_(participant, service_name,
              [this] {
                return std::vector<transport::TopicCountersSnapshot>{
                    fused_in_.counters(), ranges_in_.counters(), display_out_.counters()};
              }),
      pipeline_(config.deadline_ms, config.history_s) {
  health_.set_state(HEALTH_STARTING, "waiting for fused frames");
}

void ViewNode::run() {
  while (!node::stop_requested()) {
    health_.tick();
    // Ranges decide what is shown, so their arrival wakes the loop; frames are taken on every
    // turn (at most a few ms apart, well inside the 2-sample history at 50 Hz).
    ranges_in_.wait_for_data(std::chrono::milliseconds(4));
    take_frames();
    take_messages();
    maybe_compose();
    if (std::chrono::steady_clock::now() - last_status_ > std::chrono::milliseconds(250))
      update_status_json();
  }
  hub_.stop();
  health_.set_state(HEALTH_STOPPING, "composed " + std::to_string(stats_.composed));
}

void ViewNode::take_frames() {
  const bool side = hub_.wanted(View::side_by_side);
  struct Band {
    transport::FrameReader<GridStereoFrame>* reader;
    std::deque<Image>& ring;
    bool fused;
  };
  // A reader of a rectified topic exists only while some view shows that band. Matched, it is
  // one more reader of pools rectify-fuse sizes for the pipeline's own, and a reader that dies
  // (the viewer killed) can leave the writer's pool refusing every loan until the writer is
  // recreated (Fast DDS 2.9 with several data-sharing readers): the rectified frames the
  // pipeline ranges on would be lost for that time. The fused topic is the display's own.
  const auto reader_for = [&](std::optional<transport::FrameReader<GridStereoFrame>>& reader,
                              std::deque<Image>& ring, const char* topic, bool wanted) {
    if (wanted && !reader) {
      reader.emplace(participant_, topic, frame_reader_qos(),
                     node::count_bad_input(stats_.bad, health_));
    }
    if (!wanted && reader) {
      reader.reset();
      ring.clear();
    }
    return reader ? &*reader : nullptr;
  };
  const bool visible_wanted = side || hub_.wanted(View::visible);
  const bool infrared_wanted = side || hub_.wanted(View::infrared);
  for (Band band : {Band{&fused_in_, fused_, true},
                    Band{reader_for(visible_in_, visible_, transport::topics::kRectifiedVisible,
                                    visible_wanted),
                         visible_, false},
                    Band{reader_for(infrared_in_, infrared_, transport::topics::kRectifiedInfrared,
                                    infrared_wanted),
                         infrared_, false}}) {
    if (band.reader == nullptr) continue;
    auto samples = band.reader->take();
    if (samples.empty()) continue;
    if (band.fused) stats_.fused_frames += samples.size();
    try {
      if (copy_newest(samples, band.ring)) {
        ++stats_.copied;
      } else {
        ++stats_.overwritten;
      }
    } catch (const std::exception& e) {
      ++stats_.bad;
      health_.bad_input(band.reader->topic_name() + ": " + e.what());
    }
  }
}

void ViewNode::take_messages() {
  const std::int64_t now = transport::now_ns();
  auto ranges = ranges_in_.take();
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    ranges_.push_back(range_result_of(ranges[i], now));
    ++stats_.range_arrays;
    last_range_ns_ = now;
  }
  while (ranges_.size() > kKeptResults) ranges_.pop_front();

  auto obstacles = obstacles_in_.take();
  for (std::size_t i = 0; i < obstacles.size(); ++i)
    obstacles_.push_back(obstacle_result_of(obstacles[i]));
  while (obstacles_.size() > kKeptResults) obstacles_.pop_front();

  auto detections = detections_in_.take();
  for (std::size_t i = 0; i < detections.size(); ++i)
    detections_[detections[i].frame_seq()] = targets_of(detections[i]);
  while (detections_.size() > kKeptResults) detections_.erase(detections_.begin());

  auto timing = timing_in_.take();
  for (std::size_t i = 0; i < timing.size(); ++i) pipeline_.add_timing(timing[i], now);
  pipeline_.forget_old(now);

  auto health = health_in_.take();
  for (std::size_t i = 0; i < health.size(); ++i) pipeline_.add_health(health[i], now);
}

const ViewNode::Image* ViewNode::find(const std::deque<Image>& ring, std::uint64_t seq) const {
  for (auto it = ring.rbegin(); it != ring.rend(); ++it) {
    if (it->seq == seq) return &*it;
  }
  return nullptr;
}

const ObstacleResult* ViewNode::obstacles_for(std::uint64_t seq) const {
  for (auto it = obstacles_.rbegin(); it != obstacles_.rend(); ++it) {
    if (it->seq <= seq) return &*it;
  }
  return nullptr;
}

void ViewNode::maybe_compose() {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_compose_ < std::chrono::duration<double>(1.0 / config_.max_fps)) return;
  // The newest range result whose fused frame is held; older results are skipped.
  for (auto it = ranges_.rbegin(); it != ranges_.rend() && it->seq > last_composed_seq_; ++it) {
    if (const Image* fused = find(fused_, it->seq)) {
      compose(*fused, &*it, "");
      return;
    }
  }
  // No range result to show (detection or ranging stalled, or not started): the newest fused
  // frame with its detections, so the picture stays live.
  if (fused_.empty() || fused_.back().seq <= last_composed_seq_) return;
  const double silent_s = static_cast<double>(transport::now_ns() - last_range_ns_) / 1e9;
  if (last_range_ns_ != 0 && silent_s < config_.stale_ranges_s) return;
  char note[64];
  if (last_range_ns_ == 0) {
    std::snprintf(note, sizeof note, "waiting for ranges");
  } else {
    std::snprintf(note, sizeof note, "no ranges for %.1f s", silent_s);
  }
  compose(fused_.back(), nullptr, note);
}

void ViewNode::compose(const Image& fused, const RangeResult* ranges, const std::string& note) {
  last_compose_ = std::chrono::steady_clock::now();
  last_composed_seq_ = fused.seq;
  display::Status status;
  status.frame_seq = fused.seq;
  status.capture_time_ns = fused.capture_time_ns;
  status.latency_ms = ranges != nullptr ? ranges->latency_ms : std::nan("");
  pipeline_.fill(status);
  status.note = note;
  std::vector<display::Target> targets;
  if (ranges != nullptr) {
    targets = ranges->targets;
  } else if (const auto d = detections_.find(fused.seq); d != detections_.end()) {
    targets = d->second;
  }
  display::Overlay overlay;
  if (const ObstacleResult* o = obstacles_for(fused.seq)) {
    targets.insert(targets.end(), o->obstacles.begin(), o->obstacles.end());
    overlay = o->overlay;
  }

  try {
    const cv::Mat image = display::compose(fused.left, targets, status, overlay);
    ++stats_.composed;
    health_.frame_processed();
    // thermovis/display: the fusion-ranging image for other DDS applications.
    auto loan = display_out_.loan();
    loan->seq(fused.seq);
    loan->capture_time_ns(fused.capture_time_ns);
    transport::clear_stamps(loan->stamps());
    image.copyTo(node::prepare(*loan, node::Eye::left, image.size(), CV_8UC3));
    node::prepare(*loan, node::Eye::right, image.size(), CV_8UC3).setTo(cv::Scalar::all(0));
    loan->step(static_cast<std::uint32_t>(image.cols * 3));
    display_out_.publish(std::move(loan));
    ++stats_.published;

    const auto encode = [&](View view, const cv::Mat& composed) {
      auto frame = encode_jpeg(composed, config_.jpeg_quality);
      frame->number = ++encoded_number_[static_cast<std::size_t>(view)];
      frame->seq = fused.seq;
      frame->capture_time_ns = fused.capture_time_ns;
      frame->encoded_ns = transport::now_ns();
      ++stats_.encoded;
      if (view == View::fused) {
        hub_.note_composed(fused.capture_time_ns,
                           ranges != nullptr ? ranges->received_ns : frame->encoded_ns,
                           frame->encoded_ns);
      }
      hub_.publish(view, std::move(frame));
    };
    if (hub_.wanted(View::fused)) encode(View::fused, image);
    const Image* visible = find(visible_, fused.seq);
    const Image* infrared = find(infrared_, fused.seq);
    cv::Mat infrared_8;
    if (infrared != nullptr) {
      infrared_8 = agc_.process(infrared->left);
      // A reduced infrared frame (thermovis/geometry's infrared_reduction) shown on the grid,
      // where the targets' boxes are.
      if (infrared_8.size() != fused.left.size() && !fused.left.empty()) {
        cv::resize(infrared_8, infrared_8, fused.left.size(), 0, 0, cv::INTER_LINEAR);
      }
    }
    if (visible != nullptr && hub_.wanted(View::visible))
      encode(View::visible, display::compose(visible->left, targets, status, overlay));
    if (infrared != nullptr && hub_.wanted(View::infrared))
      encode(View::infrared, display::compose(infrared_8, targets, status, overlay));
    if (visible != nullptr && infrared != nullptr && hub_.wanted(View::side_by_side)) {
      encode(View::side_by_side,
             display::compose_side_by_side(visible->left, infrared_8, fused.left, targets, status,
                                           config_.panel_scale, overlay));
    }
  } catch (const std::exception& e) {
    health_.bad_input(std::string("composing frame ") + std::to_string(fused.seq) + ": " +
                      e.what());
    return;
  }

  hub_.set_targets_json(targets_json(status, targets));
}

void ViewNode::update_status_json() {
  last_status_ = std::chrono::steady_clock::now();
  hub_.set_status_json(pipeline_.json(transport::now_ns(), stats_));
}

}  // namespace thermovis::view
