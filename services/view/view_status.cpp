#include "view_status.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "thermovis/node/health.hpp"
#include "thermovis/transport/stamps.hpp"

namespace thermovis::view {
namespace {

// The page tells "not ranged" from a distance by -1: JSON has no NaN.
double finite_or_null(double v) { return std::isfinite(v) ? v : -1.0; }

// The fields a detection and a range share: id, label and box (rectified pixels).
template <typename Message>
display::Target boxed_target(const Message& m) {
  display::Target t;
  t.id = m.target_id();
  t.label = m.label().to_string();
  t.box = {m.box().x(), m.box().y(), m.box().width(), m.box().height()};
  return t;
}

}  // namespace

display::Target target_of(const TargetRange& range) {
  display::Target t = boxed_target(range);
  t.distance_m = range.distance_m();
  t.sigma_m = range.sigma_m();
  t.band = range.band();
  t.points = range.point_count();
  return t;
}

display::Target target_of(const Detection& detection) { return boxed_target(detection); }

std::vector<display::Target> targets_of(const DetectionArray& detections) {
  std::vector<display::Target> targets;
  for (const Detection& d : detections.detections()) targets.push_back(target_of(d));
  return targets;
}

RangeResult range_result_of(const RangeArray& ranges, std::int64_t received_ns) {
  RangeResult r;
  r.seq = ranges.frame_seq();
  r.capture_time_ns = ranges.capture_time_ns();
  r.received_ns = received_ns;
  r.latency_ms = transport::latency_ms(ranges.stamps(), ranges.capture_time_ns());
  for (const TargetRange& t : ranges.targets()) r.targets.push_back(target_of(t));
  return r;
}

ObstacleResult obstacle_result_of(const ObstacleArray& obstacles) {
  ObstacleResult r;
  r.seq = obstacles.frame_seq();
  for (const Obstacle& o : obstacles.obstacles()) {
    if (o.has_target()) continue;
    display::Target t;
    t.id = o.obstacle_id();
    t.label = o.label().to_string();
    t.box = {o.box().x(), o.box().y(), o.box().width(), o.box().height()};
    t.distance_m = o.distance_m();
    t.sigma_m = o.sigma_m();
    t.band = o.band();
    t.obstacle = true;
    r.obstacles.push_back(t);
  }
  r.overlay.free_space_row.assign(obstacles.free_space_row().begin(),
                                  obstacles.free_space_row().end());
  return r;
}

std::string targets_json(const display::Status& status,
                         const std::vector<display::Target>& targets) {
  nlohmann::json list = nlohmann::json::array();
  for (const display::Target& t : targets) {
    list.push_back({{"id", t.id},
                    {"label", t.label},
                    {"ranged", std::isfinite(t.distance_m)},
                    {"distance_m", finite_or_null(t.distance_m)},
                    {"sigma_m", t.sigma_m},
                    {"band", display::band_name(t.band)},
                    {"points", t.points},
                    {"obstacle", t.obstacle},
                    {"box", {t.box.x, t.box.y, t.box.width, t.box.height}}});
  }
  return nlohmann::json{{"frame_seq", status.frame_seq},
                        {"capture_time_ns", status.capture_time_ns},
                        {"latency_ms", finite_or_null(status.latency_ms)},
                        {"note", status.note},
                        {"targets", list}}
      .dump();
}

void PipelineStatus::add_timing(const FrameTiming& timing, std::int64_t now_ns) {
  const double ms = static_cast<double>(timing.output_time_ns() - timing.capture_time_ns()) / 1e6;
  latency_.emplace_back(now_ns, ms);
  ++frames_;
  if (ms > deadline_ms_) ++over_deadline_;
}

void PipelineStatus::forget_old(std::int64_t now_ns) {
  const auto window_ns = static_cast<std::int64_t>(history_s_ * 1e9);
  while (!latency_.empty() && now_ns - latency_.front().first > window_ns) latency_.pop_front();
}

void PipelineStatus::add_health(const Health& health, std::int64_t now_ns) {
  services_[health.service().to_string()] = Service{health, now_ns};
}

void PipelineStatus::fill(display::Status& status) const {
  status.deadline_ms = deadline_ms_;
  status.frames = frames_;
  status.over_deadline = over_deadline_;
  for (const auto& [name, s] : services_) status.deadline_misses += node::deadline_misses(s.health);
}

std::string PipelineStatus::json(std::int64_t now_ns, const ViewStats& view) const {
  nlohmann::json latency = nlohmann::json::array();
  for (const auto& [at, ms] : latency_)
    latency.push_back({static_cast<double>(at - now_ns) / 1e9, ms});
  nlohmann::json services = nlohmann::json::array();
  std::uint64_t misses = 0;
  for (const auto& [name, s] : services_) {
    const Health& h = s.health;
    const std::uint64_t service_misses = node::deadline_misses(h);
    misses += service_misses;
    services.push_back({{"service", name},
                        {"state", node::health_state_name(h.state())},
                        {"frames", h.frames_processed()},
                        {"errors", h.errors()},
                        {"deadline_misses", service_misses},
                        {"message", h.message().to_string()},
                        {"age_s", static_cast<double>(now_ns - s.seen_ns) / 1e9}});
  }
  return nlohmann::json{{"time_ns", now_ns},
                        {"deadline_ms", deadline_ms_},
                        {"history_s", history_s_},
                        {"frames", frames_},
                        {"over_deadline", over_deadline_},
                        {"deadline_misses", misses},
                        {"latency", latency},
                        {"health", services},
                        {"view",
                         {{"fused_frames", view.fused_frames},
                          {"copied", view.copied},
                          {"overwritten", view.overwritten},
                          {"bad", view.bad},
                          {"range_arrays", view.range_arrays},
                          {"composed", view.composed},
                          {"encoded", view.encoded},
                          {"published", view.published}}}}
      .dump();
}

}  // namespace thermovis::view
