#include "obstacles_node.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::obstacles_service {
namespace {

namespace ob = obstacle;

// No range for this long: no target path is running, captures do not wait for ranges.
constexpr std::chrono::seconds kRangesQuiet{1};
// Range arrays kept for captures still being searched.
constexpr std::size_t kRangesKept = 8;

GroundStatus ground_status(const ob::ObstacleResult& result, ob::PairBand band) {
  for (const ob::PairObstacles& p : result.pairs) {
    if (p.band != band) continue;
    switch (p.ground.status) {
      case ob::GroundStatus::ok:
        return GROUND_OK;
      case ob::GroundStatus::no_disparity:
        return GROUND_NO_DISPARITY;
      case ob::GroundStatus::no_ground:
        return GROUND_NO_GROUND;
    }
  }
  return GROUND_NOT_SEARCHED;
}

Band band_of_bits(unsigned bits) {
  if (bits == (ob::kVisibleBit | ob::kInfraredBit)) return BAND_FUSED;
  if (bits == ob::kInfraredBit) return BAND_INFRARED;
  if (bits == ob::kVisibleBit) return BAND_VISIBLE;
  return BAND_UNKNOWN;
}

}  // namespace

std::vector<pipeline::RangedTarget3d> targets_of(const RangeArray& ranges) {
  std::vector<pipeline::RangedTarget3d> out;
  for (const TargetRange& r : ranges.targets()) {
    const std::string name = "target " + std::to_string(r.target_id()) + " of frame " +
                             std::to_string(ranges.frame_seq());
    pipeline::RangedTarget3d t;
    t.target_id = r.target_id();
    t.label = r.label().to_string();
    t.box = node::to_rect(r.box());
    if (t.box.empty()) throw node::FrameError(name + ": box with no area or a non-finite field");
    t.sigma_m = r.sigma_m();
    t.position_m = {r.x_m(), r.y_m(), r.z_m()};
    if (!t.position_m.allFinite() || !std::isfinite(t.sigma_m) || t.sigma_m < 0) {
      throw node::FrameError(name + ": a non-finite position or a sigma that is not >= 0");
    }
    t.band = node::band_of(r.band());
    out.push_back(std::move(t));
  }
  return out;
}

ObstacleArray to_message(const pipeline::ObstacleReport& report, const ob::ObstacleResult& result,
                         const pipeline::ObstacleStage& stage) {
  ObstacleArray out;
  out.visible_ground(ground_status(result, ob::PairBand::visible));
  out.infrared_ground(ground_status(result, ob::PairBand::infrared));
  for (int i = 0; i < 3; ++i) {
    out.ground_normal()[static_cast<std::size_t>(i)] =
        static_cast<float>(report.ground_reporting.normal[i]);
  }
  out.ground_height_m(static_cast<float>(report.ground_reporting.height_m));
  std::uint32_t id = 0;
  for (const pipeline::ReportedObstacle& r : report.obstacles) {
    if (out.obstacles().size() >= MAX_OBSTACLES) break;  // the farthest are left out
    const ob::Obstacle& o = r.obstacle;
    Obstacle m;
    m.obstacle_id(id++);
    m.label(r.label.substr(0, MAX_LABEL_LENGTH));
    m.has_target(r.target_id.has_value());
    m.target_id(r.target_id.value_or(0));
    m.distance_m(static_cast<float>(o.distance_m));
    m.sigma_m(static_cast<float>(o.sigma_m));
    m.x_m(static_cast<float>(o.position_m.x()));
    m.y_m(static_cast<float>(o.position_m.y()));
    m.z_m(static_cast<float>(o.position_m.z()));
    m.width_m(static_cast<float>(o.extent_m.x()));
    m.height_m(static_cast<float>(o.extent_m.y()));
    m.depth_m(static_cast<float>(o.extent_m.z()));
    m.box(node::to_box(o.box));
    m.band(band_of_bits(o.bands));
    m.stixels(static_cast<std::uint32_t>(o.stixels));
    out.obstacles().push_back(m);
  }
  const std::size_t columns =
      std::min<std::size_t>(report.free_space_m.size(), MAX_FREE_SPACE_COLUMNS);
  out.free_space_m().assign(report.free_space_m.begin(),
                            report.free_space_m.begin() + static_cast<std::ptrdiff_t>(columns));
  out.free_space_row().assign(report.free_space_row.begin(),
                              report.free_space_row.begin() + static_cast<std::ptrdiff_t>(columns));
  out.max_distance_m(static_cast<float>(stage.options().obstacles.max_distance_m));
  return out;
}

// The frames are read as an observer's, without a DEADLINE of their own: this service is beside
// the target path (SCHED_IDLE in the shipped manifest), takes the newest capture when it is
// behind, and nothing waits for it. A requested deadline made its starved reader count misses of
// frames that came on time (the writers' offered deadlines count the late ones).
struct ObstaclesNode::BandInput {
  BandInput(transport::Participant& participant, const char* topic, ob::PairBand band_,
            const std::string& service, transport::FrameReader<GridStereoFrame>::BadFrame bad)
      : band(band_),
        reader(participant, topic, transport::observer_qos(transport::frame_topic_qos({}, 2, 2)),
               std::move(bad)),
        sequence(service, std::string(topic) + " frame") {}
  ob::PairBand band;
  transport::FrameReader<GridStereoFrame> reader;
  node::FrameSequence sequence;
};

ObstaclesNode::ObstaclesNode(transport::Participant& participant, const ObstaclesConfig& config,
                             const std::string& service_name)
    : config_(config),
      stage_(participant, config.obstacles),
      out_(participant, transport::topics::kObstacles, transport::event_topic_qos()),
      health_(participant, service_name,
              [this] {
                std::vector<transport::TopicCountersSnapshot> counters{out_.counters(),
                                                                       stage_.counters()};
                for (const auto* input : {visible_.get(), infrared_.get()})
                  if (input != nullptr) counters.push_back(input->reader.counters());
                if (ranges_in_) counters.push_back(ranges_in_->counters());
                return counters;
              }),
      ranges_(kRangesKept) {
  const auto bad_frame = node::count_bad_input(stats_.bad, health_);
  if (config.obstacles.visible) {
    visible_ = std::make_unique<BandInput>(participant, transport::topics::kRectifiedVisible,
                                           ob::PairBand::visible, service_name, bad_frame);
  }
  if (config.obstacles.infrared) {
    infrared_ = std::make_unique<BandInput>(participant, transport::topics::kRectifiedInfrared,
                                            ob::PairBand::infrared, service_name, bad_frame);
  }
  if (!visible_ && !infrared_) throw std::invalid_argument("no pair to search for obstacles");
  if (config.with_targets) {
    ranges_in_ = std::make_unique<transport::Reader<RangeArray>>(
        participant, transport::topics::kRanges, transport::event_topic_qos());
  }
  health_.set_state(HEALTH_STARTING, "no grid geometry yet (thermovis/geometry)");
}

ObstaclesNode::~ObstaclesNode() = default;

void ObstaclesNode::take_ranges() {
  if (!ranges_in_) return;
  auto arrays = ranges_in_->take();
  for (std::size_t i = 0; i < arrays.size(); ++i) {
    last_range_ = std::chrono::steady_clock::now();
    ranges_.push(arrays[i].frame_seq(), arrays[i]);
  }
}

void ObstaclesNode::take_frames(BandInput& input) {
  auto frames = input.reader.take();
  // Behind (the CPU went to the target path): only the newest frame is worth the time.
  if (frames.size() > 1) stats_.skipped += frames.size() - 1;
  for (std::size_t i = frames.size() > 0 ? frames.size() - 1 : 0; i < frames.size(); ++i) {
    const GridStereoFrame& frame = frames[i];
    try {
      if (!input.sequence.admit(frame.seq(), frame.capture_time_ns(), health_)) continue;
      if (input.sequence.last_verdict() == node::FrameOrder::Verdict::restarted) {
        // The writer counts from the start again: captures of the old count are let go.
        captures_.clear();
        ranges_.clear();
        tracks_.reset();
      }
      const std::int64_t start_ns = transport::now_ns();
      const cv::Size grid = stage_.geometry().image_size(input.band == ob::PairBand::infrared
                                                             ? pipeline::Band::infrared
                                                             : pipeline::Band::visible);
      const cv::Mat left = node::view(frame, node::Eye::left, grid, stage_.id());
      const cv::Mat right = node::view(frame, node::Eye::right, grid, stage_.id());
      if ((input.band == ob::PairBand::infrared) != (left.type() == CV_16UC1)) {
        throw node::FrameError("frame " + std::to_string(frame.seq()) + ": " +
                               (input.band == ob::PairBand::infrared
                                    ? "expected MONO16 infrared counts"
                                    : "16-bit pixels in an 8-bit band"));
      }
      if (tracked_geometry_ != stage_.id()) {
        tracks_.reset();  // another grid: the grounds tracked were of the old one
        tracked_geometry_ = stage_.id();
      }
      ob::PairObstacles pair =
          config_.track_ground
              ? stage_.stage().detect_pair(input.band, left, right, tracks_.of(input.band))
              : stage_.stage().detect_pair(input.band, left, right);
      if (!frames.still_valid(i)) {
        // The writer reused the sample while it was read: a torn image, dropped.
        ++stats_.overwritten;
        continue;
      }
      stats_.no_ground += !pair.ok();
      Capture& capture = captures_[frame.seq()];
      if (capture.first_seen == std::chrono::steady_clock::time_point{}) {
        capture.capture_ns = frame.capture_time_ns();
        capture.stamps = frame.stamps();
        capture.start_ns = start_ns;
        capture.first_seen = std::chrono::steady_clock::now();
      }
      (input.band == ob::PairBand::visible ? capture.visible : capture.infrared) = std::move(pair);
    } catch (const std::exception& e) {
      ++stats_.bad;
      health_.bad_input(input.reader.topic_name() + ": " + e.what());
    }
  }
}

void ObstaclesNode::publish_ready() {
  const auto now = std::chrono::steady_clock::now();
  while (!captures_.empty()) {
    auto it = captures_.begin();
    Capture& c = it->second;
    const bool complete = (!visible_ || c.visible) && (!infrared_ || c.infrared);
    // A later capture has the pair this one lacks: it will not come.
    bool passed = false;
    for (auto later = std::next(it); later != captures_.end(); ++later) {
      passed |= (!c.visible && later->second.visible) || (!c.infrared && later->second.infrared);
    }
    if (!complete && !passed && now - c.first_seen < config_.partner_wait) return;
    stats_.one_pair += !complete;
    publish(it->first, c);
    captures_.erase(it);
  }
}

void ObstaclesNode::publish(std::uint64_t seq, Capture& capture) {
  std::vector<ob::PairObstacles> pairs;
  if (capture.visible) pairs.push_back(std::move(*capture.visible));
  if (capture.infrared) pairs.push_back(std::move(*capture.infrared));
  const ob::ObstacleResult result = stage_.stage().combine(std::move(pairs));

  std::vector<pipeline::RangedTarget3d> targets;
  if (ranges_in_ && std::chrono::steady_clock::now() - last_range_ < kRangesQuiet) {
    const RangeArray* ranges = node::join<RangeArray>(
        ranges_, seq, config_.range_wait,
        [&](std::chrono::milliseconds wait) {
          ranges_in_->wait_for_data(wait);
          take_ranges();
        },
        node::stop_requested);
    if (ranges == nullptr) {
      ++stats_.without_ranges;
    } else {
      try {
        targets = targets_of(*ranges);
      } catch (const std::exception& e) {
        ++stats_.bad;
        ++stats_.without_ranges;
        health_.bad_input(std::string(transport::topics::kRanges) + ": " + e.what());
      }
    }
    ranges_.drop_through(seq);
  } else if (ranges_in_) {
    ++stats_.without_ranges;
  }
  const pipeline::ObstacleReport report = stage_.stage().report(result, targets);
  ObstacleArray out = to_message(report, result, stage_.stage());
  out.frame_seq(seq);
  out.capture_time_ns(capture.capture_ns);
  out.stamps(capture.stamps);
  transport::append_stamp(out.stamps(), STAGE_OBSTACLES, capture.start_ns, transport::now_ns());
  out_.write(out);
  ++stats_.processed;
  stats_.obstacles += out.obstacles().size();
  for (const Obstacle& o : out.obstacles()) stats_.targets += o.has_target();
  health_.frame_processed();
}

void ObstaclesNode::run() {
  node::wait_for_geometry(stage_, health_, "rectified frames", node::stop_requested);
  // The infrared pair comes first; without it, the visible one.
  BandInput& first = infrared_ ? *infrared_ : *visible_;
  while (!node::stop_requested()) {
    health_.tick();
    first.reader.wait_for_data(std::chrono::milliseconds(20));
    if (!stage_.refresh(health_)) {
      for (auto* input : {visible_.get(), infrared_.get()})
        if (input != nullptr) input->reader.take();
      continue;
    }
    take_ranges();
    for (auto* input : {infrared_.get(), visible_.get()})
      if (input != nullptr) take_frames(*input);
    // The newest capture's visible pair follows its infrared pair by a few milliseconds: wait
    // for it here rather than for the next capture.
    while (visible_ && infrared_ && !captures_.empty() && !captures_.rbegin()->second.visible &&
           std::chrono::steady_clock::now() - captures_.rbegin()->second.first_seen <
               config_.partner_wait &&
           !node::stop_requested()) {
      if (visible_->reader.wait_for_data(std::chrono::milliseconds(2))) take_frames(*visible_);
    }
    publish_ready();
  }
  health_.set_state(HEALTH_STOPPING, "published " + std::to_string(stats_.processed));
}

}  // namespace thermovis::obstacles_service
