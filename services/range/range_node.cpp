#include "range_node.hpp"

#include <cmath>
#include <map>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::range_service {
namespace {

// thermovis/ranges samples the writer keeps (50 a second).
constexpr std::int32_t kRangesKept = 50;

pipeline::TargetEntry entry_of(const TargetMatch& target) {
  pipeline::TargetEntry entry;
  entry.band = node::band_of(target.band());
  entry.label = target.label().to_string();
  entry.box = node::to_rect(target.box());
  entry.points.reserve(target.points().size());
  for (const PointMatch& p : target.points()) {
    match::Correspondence c;
    c.left = {p.left_x(), p.left_y()};
    c.right = {p.right_x(), p.right_y()};
    c.disparity_px = c.left.x() - c.right.x();
    c.score = 1.0;
    entry.points.push_back(c);
  }
  const RegionMatch& q = target.region();
  if (q.valid()) {
    entry.region.status = match::RegionStatus::ok;
    entry.region.anchor = {q.anchor_x(), q.anchor_y()};
    entry.region.disparity_px = q.disparity_px();
    entry.region.sigma_px = q.sigma_px();
    entry.region.contour_fraction = q.contour_fraction();
    entry.region.pixels = static_cast<int>(q.pixels());
  } else {
    entry.region.message = "the match service gave no region alignment";
  }
  return entry;
}

}  // namespace

std::vector<std::vector<const TargetMatch*>> checked_targets(const MatchArray& matches) {
  const std::string frame = "frame " + std::to_string(matches.frame_seq());
  node::check_stamps(matches.stamps(), matches.capture_time_ns(), frame);
  std::map<std::uint32_t, std::size_t> index_of;
  std::vector<std::vector<const TargetMatch*>> targets;
  for (const TargetMatch& target : matches.targets()) {
    const std::string name = "target " + std::to_string(target.target_id()) + " of " + frame;
    if (target.band() > BAND_FUSED) {
      throw std::invalid_argument(name + ": unknown band " + std::to_string(target.band()));
    }
    const auto [it, added] = index_of.emplace(target.target_id(), targets.size());
    if (added) targets.emplace_back();
    auto& entries = targets[it->second];
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
    const RegionMatch& q = target.region();
    if (q.valid() && (!std::isfinite(q.anchor_x()) || !std::isfinite(q.anchor_y()) ||
                      !std::isfinite(q.disparity_px()) || !(q.sigma_px() >= 0.0f) ||
                      !std::isfinite(q.sigma_px()) || !(q.contour_fraction() >= 0.0f) ||
                      !(q.contour_fraction() <= 1.0f))) {
      throw std::invalid_argument(name +
                                  ": region with a non-finite field, a negative sigma or a "
                                  "contour fraction outside 0..1");
    }
  }
  return targets;
}

RangeNode::RangeNode(transport::Participant& participant, const RangeConfig& config,
                     const std::string& service_name)
    : config_(config),
      stage_(participant, config.range),
      matches_in_(participant, transport::topics::kMatches, transport::event_topic_qos()),
      // A second of results kept for a reader that falls behind (another application at the
      // normal policy while the frame path runs realtime): a reliable KEEP_LAST writer resends
      // only what its history still holds.
      ranges_out_(participant, transport::topics::kRanges, transport::event_topic_qos(kRangesKept)),
      timing_out_(participant, transport::topics::kTiming, transport::event_topic_qos()),
      health_(participant, service_name, [this] {
        return std::vector<transport::TopicCountersSnapshot>{
            matches_in_.counters(), ranges_out_.counters(), timing_out_.counters(),
            stage_.counters()};
      }) {
  health_.set_state(HEALTH_STARTING, "no grid geometry yet (thermovis/geometry)");
}

void RangeNode::run() {
  node::wait_for_geometry(stage_, health_, "matches", node::stop_requested);
  while (!node::stop_requested()) {
    health_.tick();
    const bool waiting = matches_in_.wait_for_data(std::chrono::milliseconds(100));
    const bool have_stage = stage_.refresh(health_);
    if (!waiting) continue;
    auto arrays = matches_in_.take();
    if (!have_stage) {
      stats_.no_geometry += arrays.size();
      continue;
    }
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
  // The whole array is checked before any target is ranged: a bad array is rejected as a whole.
  for (const std::vector<const TargetMatch*>& entries : checked_targets(matches)) {
    std::vector<pipeline::TargetEntry> stage_entries;
    const TargetMatch* shown = entries.front();  // label and box: the non-infrared entry's
    for (const TargetMatch* e : entries) {
      stage_entries.push_back(entry_of(*e));
      if (e->band() != BAND_INFRARED) shown = e;
    }
    const pipeline::RangedTarget r = stage_.stage().range(stage_entries);
    if (!r.ok()) {
      ++stats_.unranged;
      continue;
    }
    TargetRange t;
    t.target_id(shown->target_id());
    t.label(shown->label());
    // Distances of the contract are from the left visible camera's centre (infrared points
    // were triangulated from the left infrared camera's).
    t.distance_m(static_cast<float>(r.distance_m));
    t.sigma_m(static_cast<float>(r.range.sigma_m));
    t.x_m(static_cast<float>(r.position_m.x()));
    t.y_m(static_cast<float>(r.position_m.y()));
    t.z_m(static_cast<float>(r.position_m.z()));
    t.box(shown->box());
    t.point_count(static_cast<std::uint32_t>(r.range.points_used + r.range.region_pixels));
    t.band(node::to_message(r.band));
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
