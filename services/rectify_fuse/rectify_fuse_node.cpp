#include "rectify_fuse_node.hpp"

#include <cmath>
#include <future>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::rectify_fuse {
namespace {

using node::Eye;

// How long a visible capture waits for its infrared partner (the bridge publishes the two
// together).
constexpr std::chrono::milliseconds kPartnerWait{20};

// Readers of raw frames: this node holds at most one sample of each band while pairing.
transport::TopicQos raw_qos(std::chrono::nanoseconds deadline) {
  return transport::frame_topic_qos(deadline, 2, 2);
}

// Writers of grid frames: their pools hold a slot per reader that may keep one sample loaned
// (rectified infrared: detect, match, obstacles, thermovis-view, and one more DDS application).
// With fewer slots than readers a third reader (the viewer) left no slot free and stalled this
// service ("every pool slot is loaned or unread").
constexpr std::int32_t kGridFrameReaders = 5;

transport::TopicQos grid_qos(std::chrono::nanoseconds deadline) {
  return transport::frame_topic_qos(deadline, 2, kGridFrameReaders);
}

// Whether the fused topic is decimated (fused_rate_hz).
bool fusion_decimated(const RectifyFuseConfig& config) {
  return config.fused_rate_hz > 0.0 && !config.fuse_right_eye;
}

// The fused writer's DEADLINE period (the node's construction checks the rate here).
std::chrono::nanoseconds fused_deadline(const RectifyFuseConfig& config) {
  if (!(config.fused_rate_hz >= 0.0) || !std::isfinite(config.fused_rate_hz)) {
    throw std::invalid_argument("fused rate must be 0 (every capture) or a positive rate, not " +
                                std::to_string(config.fused_rate_hz));
  }
  if (!fusion_decimated(config) || config.deadline.count() == 0) return config.deadline;
  return config.deadline +
         std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / config.fused_rate_hz));
}

// The geometry of the configured grid, checked against what a GridStereoFrame can carry.
pipeline::PipelineGeometry grid_geometry(const camera::Rig& rig, const pipeline::GridOptions& o) {
  pipeline::PipelineGeometry g = pipeline::make_geometry(rig, o);
  if (static_cast<std::size_t>(g.grid_size().area()) * 3 > GRID_IMAGE_BYTES) {
    throw std::invalid_argument("rectified grid " + std::to_string(g.grid.width) + "x" +
                                std::to_string(g.grid.height) +
                                " does not fit the GridStereoFrame type; choose a smaller width");
  }
  return g;
}

// A grid frame's header from its capture's visible frame, with this stage's stamp.
void copy_header(GridStereoFrame& to, const VisibleStereoFrame& from, std::uint32_t geometry_id,
                 std::int64_t since_ns) {
  to.seq(from.seq());
  to.capture_time_ns(from.capture_time_ns());
  to.stamps(from.stamps());
  to.geometry_id(geometry_id);
  transport::append_stamp(to.stamps(), STAGE_RECTIFY_FUSE, since_ns, transport::now_ns());
}

}  // namespace

RectifyFuseNode::RectifyFuseNode(transport::Participant& participant, const camera::Rig& rig,
                                 const RectifyFuseConfig& config, const std::string& service_name)
    : config_(config),
      stage_(rig, grid_geometry(rig, config.grid), config.stage),
      geometry_id_(stage_.geometry().id()),
      visible_in_(participant, transport::topics::kVisibleFrames, raw_qos(config.deadline),
                  node::count_bad_input(stats_.bad, health_)),
      infrared_in_(participant, transport::topics::kInfraredFrames, raw_qos(config.deadline),
                   node::count_bad_input(stats_.bad, health_)),
      rectified_visible_out_(participant, transport::topics::kRectifiedVisible,
                             grid_qos(config.deadline)),
      rectified_infrared_out_(participant, transport::topics::kRectifiedInfrared,
                              grid_qos(config.deadline)),
      fused_out_(participant, transport::topics::kFused, grid_qos(fused_deadline(config))),
      geometry_out_(participant, stage_.geometry()),
      health_(participant, service_name,
              [this] {
                return std::vector<transport::TopicCountersSnapshot>{
                    visible_in_.counters(),
                    infrared_in_.counters(),
                    rectified_visible_out_.counters(),
                    rectified_infrared_out_.counters(),
                    fused_out_.counters(),
                    geometry_out_.counters()};
              }),
      sequence_(service_name, "visible frame"),
      infrared_held_(1) {
  health_.set_state(HEALTH_STARTING, "grid " + std::to_string(grid_size().width) + "x" +
                                         std::to_string(grid_size().height) +
                                         ", waiting for frames");
}

RectifyFuseStats RectifyFuseNode::stats() const {
  RectifyFuseStats s = stats_;
  s.repeated = sequence_.repeated();
  s.bad += sequence_.stale();
  return s;
}

void RectifyFuseNode::take_infrared(std::chrono::milliseconds wait) {
  if (wait.count() > 0) infrared_in_.wait_for_data(wait);
  // One sample at a time, and one held (infrared_held_ keeps one): the reader's history holds
  // two loans at most, and a take while both are held fails (OUT_OF_RESOURCES).
  auto taken = std::make_shared<transport::FrameSamples<InfraredStereoFrame>>(infrared_in_.take(1));
  if (!taken->empty()) infrared_held_.push((*taken)[0].seq(), HeldInfrared{taken, 0});
}

void RectifyFuseNode::run() {
  using std::chrono::milliseconds;
  while (!node::stop_requested()) {
    health_.tick();
    if (!visible_in_.wait_for_data(milliseconds(100))) continue;
    auto visible = visible_in_.take();
    if (visible.empty()) continue;
    // Only the newest capture is worth processing; older ones are dropped (never queued).
    stats_.dropped += visible.size() - 1;
    const VisibleStereoFrame& vis = visible[visible.size() - 1];
    if (!sequence_.admit(vis.seq(), vis.capture_time_ns(), health_)) continue;
    if (sequence_.last_verdict() == node::FrameOrder::Verdict::restarted) infrared_held_.clear();
    // Its infrared partner (same seq) is published with it.
    const HeldInfrared* infrared = node::join<HeldInfrared>(
        infrared_held_, vis.seq(), kPartnerWait, [this](milliseconds wait) { take_infrared(wait); },
        node::stop_requested);
    if (infrared == nullptr) {
      ++stats_.dropped;
    } else {
      try {
        process(vis, infrared->frame());
        ++stats_.processed;
        health_.frame_processed();
      } catch (const std::exception& e) {
        ++stats_.bad;
        health_.bad_input(e.what());
      }
    }
    infrared_held_.drop_through(vis.seq());  // the loans go back to the bridge's pool
  }
  health_.set_state(HEALTH_STOPPING, "processed " + std::to_string(stats_.processed) + ", fused " +
                                         std::to_string(stats_.fused));
}

void RectifyFuseNode::process(const VisibleStereoFrame& visible,
                              const InfraredStereoFrame& infrared) {
  const std::int64_t start_ns = transport::now_ns();
  const cv::Size grid = grid_size();
  auto out_visible = rectified_visible_out_.loan();
  auto out_infrared = rectified_infrared_out_.loan();
  // The rectified pairs first, infrared before visible: detection works on the infrared alone
  // and starts while the visible pair is rectified; matching needs both. With parallel_bands
  // the visible pair is rectified on a second thread meanwhile (its remap costs more than the
  // infrared's). The fusion, which only the display and fused-band matching need, comes last.
  std::array<cv::Mat, 2> rect_visible, rect_infrared;
  const auto rectify_visible = [&] {
    for (const Eye eye : {Eye::left, Eye::right}) {
      // view() checks the headers; the stage checks the sizes against the rig's cameras.
      cv::Mat& out = rect_visible[eye == Eye::left ? 0 : 1];
      out = node::prepare(*out_visible, eye, grid, stage_.visible_mono() ? CV_8UC1 : CV_8UC3);
      stage_.rectify_visible(eye, node::view(visible, eye), out);
    }
    out_visible->eyes(EYES_BOTH);
  };
  std::future<void> visible_done;
  if (config_.parallel_bands) visible_done = std::async(std::launch::async, rectify_visible);
  const cv::Size infrared_size = stage_.geometry().image_size(pipeline::Band::infrared);
  for (const Eye eye : {Eye::left, Eye::right}) {
    cv::Mat& out = rect_infrared[eye == Eye::left ? 0 : 1];
    out = node::prepare(*out_infrared, eye, infrared_size, CV_16UC1);
    stage_.rectify_infrared(eye, node::view(infrared, eye), out);
  }
  out_infrared->eyes(EYES_BOTH);
  copy_header(*out_infrared, visible, geometry_id_, start_ns);
  rectified_infrared_out_.publish(std::move(out_infrared));
  if (visible_done.valid()) {
    visible_done.get();  // rethrows a bad visible frame's error
  } else {
    rectify_visible();
  }
  copy_header(*out_visible, visible, geometry_id_, start_ns);
  rectified_visible_out_.publish(std::move(out_visible));
  // Reading the published samples stays safe: this writer reuses a pool slot only at its next
  // loan, which comes with the next capture.
  fuse(rect_infrared, rect_visible, visible);
}

void RectifyFuseNode::fuse(const std::array<cv::Mat, 2>& rect_infrared,
                           const std::array<cv::Mat, 2>& rect_visible,
                           const VisibleStereoFrame& visible) {
  if (fused_out_.readers() == 0) {
    // The last reader has gone: a new writer, so that DEADLINE QoS does not count the periods
    // nobody reads as offered and missed (the old writer's instance keeps its deadline timer).
    if (fused_had_readers_) fused_out_.recreate();
    fused_had_readers_ = false;
    return;
  }
  fused_had_readers_ = true;
  if (fusion_decimated(config_)) {
    const std::int64_t since_ns = visible.capture_time_ns() - last_fused_capture_ns_;
    // A capture time before the last one fused: the bridge restarted; fuse it.
    if (last_fused_capture_ns_ != 0 && since_ns >= 0 &&
        static_cast<double>(since_ns) < 0.9e9 / config_.fused_rate_hz) {
      ++stats_.fusion_skipped;
      return;
    }
    last_fused_capture_ns_ = visible.capture_time_ns();
  }
  const std::int64_t fusion_start_ns = transport::now_ns();
  auto out_fused = fused_out_.loan();
  const cv::Size grid = grid_size();
  const int fused_eyes = config_.fuse_right_eye ? 2 : 1;
  for (int i = 0; i < fused_eyes; ++i) {
    const Eye eye = i == 0 ? Eye::left : Eye::right;
    // The fusion writes into the loaned sample (the buffer has the output's size and type).
    cv::Mat fused = node::prepare(*out_fused, eye, grid, CV_8UC3);
    const auto k = static_cast<std::size_t>(i);
    stage_.fuse(eye, rect_infrared[k],
                stage_.fusion_visible(eye, rect_visible[k], node::view(visible, eye)), fused);
  }
  out_fused->eyes(config_.fuse_right_eye ? EYES_BOTH : EYES_LEFT);
  copy_header(*out_fused, visible, geometry_id_, fusion_start_ns);
  fused_out_.publish(std::move(out_fused));
  ++stats_.fused;
}

}  // namespace thermovis::rectify_fuse
