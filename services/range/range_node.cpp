#include "range_node.hpp"

#include <cmath>
#include <set>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/range/stereo_ranger.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::range_service {
namespace {

std::vector<match::Correspondence> correspondences_of(const TargetMatch& target) {
  std::vector<match::Correspondence> out;
  out.reserve(target.points().size());
  for (const PointMatch& p : target.points()) {
    match::Correspondence c;
    c.left = {p.left_x(), p.left_y()};
    c.right = {p.right_x(), p.right_y()};
    c.disparity_px = c.left.x() - c.right.x();
    c.score = 1.0;
    out.push_back(c);
  }
  return out;
}

range::RangingGeometry ranging_geometry(const rectify::StereoGeometry& stereo) {
  return range::RangingGeometry{stereo.grid, stereo.baseline_m, stereo.T_ref_left_rect};
}

}  // namespace

RangeNode::Geometries RangeNode::geometries_of(const camera::Rig& rig,
                                               const node::GridOptions& grid) {
  const auto visible = node::pipeline_geometry(rig, grid);
  return {ranging_geometry(visible),
          ranging_geometry(node::registered_infrared_geometry(rig, visible))};
}

RangeNode::RangeNode(transport::Participant& participant, const camera::Rig& rig,
                     const RangeConfig& config, const std::string& service_name)
    : config_(config),
      geometry_(geometries_of(rig, config.grid)),
      T_camera_ref_(rig.camera(rig.visible.left).T_ref_cam.inverse()),
      matches_in_(participant, transport::topics::kMatches, transport::event_topic_qos()),
      ranges_out_(participant, transport::topics::kRanges, transport::event_topic_qos()),
      timing_out_(participant, transport::topics::kTiming, transport::event_topic_qos()),
      health_(participant, service_name, [this] {
        return std::vector<transport::TopicCountersSnapshot>{
            matches_in_.counters(), ranges_out_.counters(), timing_out_.counters()};
      }) {
  health_.set_state(HEALTH_STARTING, "waiting for matches");
}

void RangeNode::run() {
  while (!node::stop_requested()) {
    health_.tick();
    if (!matches_in_.wait_for_data(std::chrono::milliseconds(100))) continue;
    auto arrays = matches_in_.take();
    for (std::size_t i = 0; i < arrays.size(); ++i) {
      try {
        answer(arrays[i]);
        ++stats_.processed;
        health_.frame_processed();
      } catch (const std::exception& e) {
        ++stats_.bad;
        health_.bad_input(std::string(transport::topics::kMatches) + ": " + e.what());
      }
    }
  }
  health_.set_state(HEALTH_STOPPING, "answered " + std::to_string(stats_.processed));
}

void RangeNode::answer(const MatchArray& matches) {
  const std::int64_t start_ns = transport::now_ns();
  RangeArray out;
  out.frame_seq(matches.frame_seq());
  out.capture_time_ns(matches.capture_time_ns());
  const std::string frame = "frame " + std::to_string(matches.frame_seq());
  node::check_stamps(matches.stamps(), matches.capture_time_ns(), frame);
  // The whole array is checked before any target is ranged: a bad array is rejected as a whole.
  std::set<std::uint32_t> ids;
  for (const TargetMatch& target : matches.targets()) {
    const std::string name = "target " + std::to_string(target.target_id()) + " of " + frame;
    if (!ids.insert(target.target_id()).second)
      throw std::invalid_argument(name + ": target id given twice");
    // BAND_UNKNOWN (a writer that does not say) is ranged as visible, like BAND_FUSED.
    if (target.band() > BAND_FUSED) {
      throw std::invalid_argument(name + ": unknown band " + std::to_string(target.band()));
    }
    for (std::size_t i = 0; i < target.points().size(); ++i) {
      const PointMatch& p = target.points()[i];
      if (!std::isfinite(p.left_x()) || !std::isfinite(p.left_y()) || !std::isfinite(p.right_x()) ||
          !std::isfinite(p.right_y())) {
        throw std::invalid_argument(name + ": point " + std::to_string(i) +
                                    " has a non-finite coordinate");
      }
    }
  }
  for (const TargetMatch& target : matches.targets()) {
    const cv::Rect box = node::to_rect(target.box());
    if (box.empty()) {
      throw std::invalid_argument("target " + std::to_string(target.target_id()) + " of " + frame +
                                  ": box with no area or a non-finite field");
    }
    // range_target skips points outside the box.
    const range::RangingGeometry& geometry =
        target.band() == BAND_INFRARED ? geometry_.infrared : geometry_.visible;
    range::RangeOptions options = config_.range;
    if (!config_.surface) options.shape = range::TargetShape::for_class(target.label().to_string());
    range::TargetRange r = range::range_target(geometry, box, correspondences_of(target), options);
    if (!config_.surface && options.shape.empty())
      range::move_to_centre(r, geometry, range::surface_to_centre_m(target.label().to_string()));
    if (r.status != range::RangeStatus::ok || !std::isfinite(r.distance_m)) {
      ++stats_.unranged;
      continue;
    }
    const Eigen::Vector3d p = T_camera_ref_ * r.position_m;
    TargetRange t;
    t.target_id(target.target_id());
    t.label(target.label());
    // Distances of the contract are from the left visible camera's centre (infrared points
    // were triangulated from the left infrared camera's).
    t.distance_m(static_cast<float>(target.band() == BAND_INFRARED ? p.norm() : r.distance_m));
    t.sigma_m(static_cast<float>(r.sigma_m));
    t.x_m(static_cast<float>(p.x()));
    t.y_m(static_cast<float>(p.y()));
    t.z_m(static_cast<float>(p.z()));
    t.box(target.box());
    t.point_count(static_cast<std::uint32_t>(r.points_used));
    t.band(target.band());
    out.targets().push_back(t);
    ++stats_.ranged;
  }
  out.stamps(matches.stamps());
  const std::int64_t end_ns = transport::now_ns();
  transport::append_stamp(out.stamps(), STAGE_RANGE, start_ns, end_ns);
  ranges_out_.write(out);
  FrameTiming timing;
  timing.frame_seq(out.frame_seq());
  timing.capture_time_ns(out.capture_time_ns());
  timing.output_time_ns(transport::now_ns());
  timing.stamps(out.stamps());
  timing_out_.write(timing);
}

}  // namespace thermovis::range_service
