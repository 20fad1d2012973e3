#include "range_node.hpp"

#include <cmath>
#include <map>
#include <stdexcept>
#include <vector>

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

// The infrared pair shown on the visible grid: its right eye is off the grid's x axis (the two
// baselines differ in direction), so points are triangulated from the true right centre.
range::RangingGeometry registered_ranging_geometry(const rectify::StereoGeometry& stereo) {
  range::RangingGeometry g = ranging_geometry(stereo);
  g.right_centre_m = stereo.T_ref_left_rect.inverse() * stereo.T_ref_right_rect.translation();
  return g;
}

}  // namespace

RangeNode::Geometries RangeNode::geometries_of(const camera::Rig& rig,
                                               const node::GridOptions& grid) {
  const auto visible = node::pipeline_geometry(rig, grid);
  return {ranging_geometry(visible),
          registered_ranging_geometry(node::registered_infrared_geometry(rig, visible))};
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
  // A target id comes once, or twice with one entry on the infrared pair and one on the other
  // (the match service's --band both): their ranges are combined.
  std::map<std::uint32_t, std::vector<const TargetMatch*>> by_id;
  std::vector<std::uint32_t> order;
  for (const TargetMatch& target : matches.targets()) {
    const std::string name = "target " + std::to_string(target.target_id()) + " of " + frame;
    // BAND_UNKNOWN (a writer that does not say) is ranged as visible, like BAND_FUSED.
    if (target.band() > BAND_FUSED) {
      throw std::invalid_argument(name + ": unknown band " + std::to_string(target.band()));
    }
    auto& entries = by_id[target.target_id()];
    if (entries.empty()) order.push_back(target.target_id());
    for (const TargetMatch* other : entries) {
      if ((other->band() == BAND_INFRARED) == (target.band() == BAND_INFRARED)) {
        throw std::invalid_argument(name + ": target id given twice for one pair");
      }
    }
    entries.push_back(&target);
    for (std::size_t i = 0; i < target.points().size(); ++i) {
      const PointMatch& p = target.points()[i];
      if (!std::isfinite(p.left_x()) || !std::isfinite(p.left_y()) || !std::isfinite(p.right_x()) ||
          !std::isfinite(p.right_y())) {
        throw std::invalid_argument(name + ": point " + std::to_string(i) +
                                    " has a non-finite coordinate");
      }
    }
    if (node::to_rect(target.box()).empty()) {
      throw std::invalid_argument(name + ": box with no area or a non-finite field");
    }
  }
  // One entry's range: its pair's geometry, the class's shape (or the surface with --surface).
  auto range_one = [&](const TargetMatch& target, double& shared_sigma) {
    const range::RangingGeometry& geometry =
        target.band() == BAND_INFRARED ? geometry_.infrared : geometry_.visible;
    const std::string label = target.label().to_string();
    range::RangeOptions options = config_.range;
    if (!config_.surface) options.shape = range::TargetShape::for_class(label);
    shared_sigma = options.shape.empty() ? 0.0 : options.shape_sigma_m;
    // range_target skips points outside the box.
    range::TargetRange r = range::range_target(geometry, node::to_rect(target.box()),
                                               correspondences_of(target), options);
    if (!config_.surface && options.shape.empty())
      range::move_to_centre(r, geometry, range::surface_to_centre_m(label));
    return r;
  };
  for (std::uint32_t id : order) {
    const std::vector<const TargetMatch*>& entries = by_id[id];
    const TargetMatch* shown = entries.front();  // label and box: the non-infrared entry's
    for (const TargetMatch* e : entries)
      if (e->band() != BAND_INFRARED) shown = e;
    double shared_sigma = 0.0;
    range::TargetRange r = range_one(*entries.front(), shared_sigma);
    Band band = entries.front()->band();
    if (entries.size() == 2) {
      // Two pairs' independent measurements (the shape's error is one error in both), or the
      // one pair that gave a range.
      range::CombinedFrom from = range::CombinedFrom::neither;
      r = range::combine_ranges(r, range_one(*entries[1], shared_sigma), geometry_.visible,
                                shared_sigma, &from);
      if (from == range::CombinedFrom::both) band = BAND_FUSED;
      if (from == range::CombinedFrom::b) band = entries[1]->band();
    }
    if (r.status != range::RangeStatus::ok || !std::isfinite(r.distance_m)) {
      ++stats_.unranged;
      continue;
    }
    const Eigen::Vector3d p = T_camera_ref_ * r.position_m;
    TargetRange t;
    t.target_id(id);
    t.label(shown->label());
    // Distances of the contract are from the left visible camera's centre (infrared points
    // were triangulated from the left infrared camera's).
    t.distance_m(static_cast<float>(p.norm()));
    t.sigma_m(static_cast<float>(r.sigma_m));
    t.x_m(static_cast<float>(p.x()));
    t.y_m(static_cast<float>(p.y()));
    t.z_m(static_cast<float>(p.z()));
    t.box(shown->box());
    t.point_count(static_cast<std::uint32_t>(r.points_used));
    t.band(band);
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
