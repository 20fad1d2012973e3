#include "rectify_fuse_node.hpp"

#include <future>
#include <iostream>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::rectify_fuse {
namespace {

using node::Eye;

// Readers of raw frames: this node holds at most one sample of each band while pairing.
transport::TopicQos raw_qos(std::chrono::nanoseconds deadline) {
  return transport::frame_topic_qos(deadline, 2, 2);
}

// Writers of grid frames: their pools hold a slot per reader that may keep one sample loaned
// (rectified infrared: detect, match, thermovis-view, and one more DDS application). With
// fewer slots than readers a third reader (the viewer) left no slot free and stalled this
// service ("every pool slot is loaned or unread").
constexpr std::int32_t kGridFrameReaders = 4;

transport::TopicQos grid_qos(std::chrono::nanoseconds deadline) {
  return transport::frame_topic_qos(deadline, 2, kGridFrameReaders);
}

std::unique_ptr<fpga::FastRemapper> remapper(const cv::Mat& map, const camera::RigCamera& camera) {
  return std::make_unique<fpga::FastRemapper>(
      fpga::FixedPointMap::from_float(map, camera.model->image_size()));
}

void copy_header(const VisibleStereoFrame& from, GridStereoFrame& to, std::int64_t start_ns) {
  to.seq(from.seq());
  to.capture_time_ns(from.capture_time_ns());
  to.stamps(from.stamps());
  transport::append_stamp(to.stamps(), STAGE_RECTIFY_FUSE, start_ns, transport::now_ns());
}

}  // namespace

RectifyFuseNode::RectifyFuseNode(transport::Participant& participant, const camera::Rig& rig,
                                 const RectifyFuseConfig& config, const std::string& service_name)
    : config_(config),
      visible_in_(participant, transport::topics::kVisibleFrames, raw_qos(config.deadline)),
      infrared_in_(participant, transport::topics::kInfraredFrames, raw_qos(config.deadline)),
      rectified_visible_out_(participant, transport::topics::kRectifiedVisible,
                             grid_qos(config.deadline)),
      rectified_infrared_out_(participant, transport::topics::kRectifiedInfrared,
                              grid_qos(config.deadline)),
      fused_out_(participant, transport::topics::kFused, grid_qos(config.deadline)),
      health_(participant, service_name, [this] {
        return std::vector<transport::TopicCountersSnapshot>{
            visible_in_.counters(), infrared_in_.counters(), rectified_visible_out_.counters(),
            rectified_infrared_out_.counters(), fused_out_.counters()};
      }) {
  health_.set_state(HEALTH_STARTING, "computing the composed maps");
  const rectify::StereoGeometry geometry = node::pipeline_geometry(rig, config_.grid);
  grid_size_ = geometry.grid.image_size();
  if (static_cast<std::size_t>(grid_size_.area()) * 3 > GRID_IMAGE_BYTES) {
    throw std::invalid_argument("rectified grid " + std::to_string(grid_size_.width) + "x" +
                                std::to_string(grid_size_.height) +
                                " does not fit the GridStereoFrame type; choose a smaller width");
  }
  // Each eye's two cameras on that eye's rectified frame; the infrared ones registered at the
  // configured distance (their centres are not the eye's).
  const double registration = config_.grid.registration_distance_m;
  const auto map_for = [&](const std::string& camera, const Eigen::Isometry3d& T_ref_rect,
                           double distance) {
    const auto& cam = rig.camera(camera);
    return remapper(rectify::build_map(cam, T_ref_rect, geometry.grid, distance), cam);
  };
  visible_maps_[0] = map_for(rig.visible.left, geometry.T_ref_left_rect, 0.0);
  visible_maps_[1] = map_for(rig.visible.right, geometry.T_ref_right_rect, 0.0);
  infrared_maps_[0] = map_for(rig.infrared.left, geometry.T_ref_left_rect, registration);
  infrared_maps_[1] = map_for(rig.infrared.right, geometry.T_ref_right_rect, registration);
  agc_ = {enhance::InfraredAgc(config_.agc), enhance::InfraredAgc(config_.agc)};
  health_.set_state(HEALTH_STARTING, "grid " + std::to_string(grid_size_.width) + "x" +
                                         std::to_string(grid_size_.height) +
                                         ", waiting for frames");
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
    const std::uint64_t last_seq = order_.last_seq();
    switch (order_.check(vis.seq(), vis.capture_time_ns())) {
      case node::FrameOrder::Verdict::repeated:
        ++stats_.repeated;  // a capture seen before: never processed twice
        continue;
      case node::FrameOrder::Verdict::stale:
        ++stats_.bad;
        health_.bad_input("visible frame " + std::to_string(vis.seq()) + " captured before frame " +
                          std::to_string(last_seq) + ": out of order, dropped");
        continue;
      case node::FrameOrder::Verdict::restarted:
        // The bridge restarted and counts from the start again: follow it.
        std::cerr << "thermovis-rectify-fuse: raw frames start again at " << vis.seq() << " after "
                  << last_seq << " with a later capture time (their writer restarted)" << std::endl;
        break;
      case node::FrameOrder::Verdict::next:
        break;
    }
    // Its infrared partner (same seq) is published with it: look for it briefly.
    bool done = false;
    for (int attempt = 0; attempt < 10 && !done && !node::stop_requested(); ++attempt) {
      auto infrared = infrared_in_.take();
      for (std::size_t i = 0; i < infrared.size() && !done; ++i) {
        if (infrared[i].seq() != vis.seq()) continue;
        try {
          process(vis, infrared[i]);
          ++stats_.processed;
          health_.frame_processed();
        } catch (const std::exception& e) {
          ++stats_.bad;
          health_.bad_input(e.what());
        }
        done = true;
      }
      if (!infrared.empty() && infrared[infrared.size() - 1].seq() > vis.seq()) break;  // gone
      if (!done) infrared_in_.wait_for_data(milliseconds(2));
    }
    if (!done) ++stats_.dropped;
  }
  health_.set_state(HEALTH_STOPPING, "processed " + std::to_string(stats_.processed));
}

void RectifyFuseNode::process(const VisibleStereoFrame& visible,
                              const InfraredStereoFrame& infrared) {
  const std::int64_t start_ns = transport::now_ns();
  auto out_visible = rectified_visible_out_.loan();
  auto out_infrared = rectified_infrared_out_.loan();
  auto out_fused = fused_out_.loan();
  // The rectified pairs first, infrared before visible: detection works on the infrared alone
  // and starts while the visible pair is rectified; matching needs both. With parallel_bands
  // the visible pair is rectified on a second thread meanwhile (its remap costs more than the
  // infrared's). The fusion, which only the display and fused-band matching need, comes last.
  std::array<cv::Mat, 2> rect_visible, rect_infrared;
  const auto rectify_visible = [&] {
    for (const Eye eye : {Eye::left, Eye::right}) {
      const int i = eye == Eye::left ? 0 : 1;
      // view() checks the headers; the remappers check the sizes against the rig's cameras.
      rect_visible[i] = node::prepare(*out_visible, eye, grid_size_, CV_8UC3);
      visible_maps_[i]->remap(node::view(visible, eye), rect_visible[i]);
    }
    out_visible->eyes(EYES_BOTH);
  };
  std::future<void> visible_done;
  if (config_.parallel_bands) visible_done = std::async(std::launch::async, rectify_visible);
  for (const Eye eye : {Eye::left, Eye::right}) {
    const int i = eye == Eye::left ? 0 : 1;
    // The rectified infrared keeps its raw counts (detection thresholds on temperature, not on
    // equalised grey levels); the gain-controlled image goes into the fusion.
    rect_infrared[i] = node::prepare(*out_infrared, eye, grid_size_, CV_16UC1);
    infrared_maps_[i]->remap(node::view(infrared, eye), rect_infrared[i]);
  }
  out_infrared->eyes(EYES_BOTH);
  copy_header(visible, *out_infrared, start_ns);
  rectified_infrared_out_.publish(std::move(out_infrared));
  if (visible_done.valid()) {
    visible_done.get();  // rethrows a bad visible frame's error
  } else {
    rectify_visible();
  }
  copy_header(visible, *out_visible, start_ns);
  rectified_visible_out_.publish(std::move(out_visible));
  // Reading the published samples stays safe: this writer reuses a pool slot only at its next
  // loan, which comes with the next capture.
  const std::int64_t fusion_start_ns = transport::now_ns();
  const int fused_eyes = config_.fuse_right_eye ? 2 : 1;
  for (int i = 0; i < fused_eyes; ++i) {
    const Eye eye = i == 0 ? Eye::left : Eye::right;
    const cv::Mat infrared_agc = agc_[i].process(rect_infrared[i]);
    cv::Mat fused = node::prepare(*out_fused, eye, grid_size_, CV_8UC3);
    // The fusion writes into the loaned sample (the buffer has the output's size and type).
    fuse::fuse(infrared_agc, rect_visible[i], fused, config_.fusion);
  }
  out_fused->eyes(config_.fuse_right_eye ? EYES_BOTH : EYES_LEFT);
  copy_header(visible, *out_fused, fusion_start_ns);
  fused_out_.publish(std::move(out_fused));
}

}  // namespace thermovis::rectify_fuse
