#include "match_node.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/range/ranging.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::match_service {
namespace {

// How long a detection array waits for its frame.
constexpr std::chrono::milliseconds kFrameWait{40};

// Counts of the region both eyes' searches look at, stretched linearly to 8 bits between the
// left region's 0.5 and 99.5 percentiles (the same mapping for both eyes).
void stretch_counts(const cv::Mat& left, const cv::Mat& right, cv::Mat& left8, cv::Mat& right8) {
  std::vector<std::uint16_t> values;
  values.reserve(static_cast<std::size_t>(left.total()));
  for (int r = 0; r < left.rows; ++r) {
    const auto* row = left.ptr<std::uint16_t>(r);
    for (int c = 0; c < left.cols; ++c)
      if (row[c] != 0) values.push_back(row[c]);  // 0: outside the camera's field
  }
  double lo = 0, hi = 1;
  if (!values.empty()) {
    const auto at = [&](double q) {
      auto it = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
      std::nth_element(values.begin(), it, values.end());
      return static_cast<double>(*it);
    };
    lo = at(0.005);
    hi = std::max(lo + 1.0, at(0.995));
  }
  const double gain = 255.0 / (hi - lo);
  left.convertTo(left8, CV_8U, gain, -lo * gain);
  right.convertTo(right8, CV_8U, gain, -lo * gain);
}

cv::Mat grey_copy(const cv::Mat& image) {
  cv::Mat grey;
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.type() == CV_8UC1 || image.type() == CV_16UC1) {
    grey = image.clone();
  } else {
    throw node::FrameError("unsupported pixel type for matching");
  }
  return grey;
}

const char* topic_of(BandChoice band) {
  switch (band) {
    case BandChoice::fused:
      return transport::topics::kFused;
    case BandChoice::infrared:
      return transport::topics::kRectifiedInfrared;
    default:
      return transport::topics::kRectifiedVisible;
  }
}

Band band_of(BandChoice band) {
  switch (band) {
    case BandChoice::fused:
      return BAND_FUSED;
    case BandChoice::infrared:
      return BAND_INFRARED;
    default:
      return BAND_VISIBLE;
  }
}

}  // namespace

BandChoice parse_band(const std::string& name) {
  if (name == "visible") return BandChoice::visible;
  if (name == "infrared") return BandChoice::infrared;
  if (name == "fused") return BandChoice::fused;
  if (name == "auto") return BandChoice::automatic;
  if (name == "both") return BandChoice::both;
  throw std::invalid_argument("unknown band '" + name + "' (visible, infrared, fused, auto, both)");
}

struct MatchNode::BandInput {
  BandInput(transport::Participant& participant, const char* topic, Band band_,
            std::chrono::nanoseconds deadline)
      : band(band_), reader(participant, topic, transport::frame_topic_qos(deadline, 2, 2)) {}
  Band band;
  transport::Reader<GridStereoFrame> reader;
  std::deque<Pair> pairs;  // oldest first
  node::FrameOrder order;  // of the frames taken
};

MatchNode::MatchNode(transport::Participant& participant, const camera::Rig& rig,
                     const MatchConfig& config, const std::string& service_name)
    : config_(config),
      primary_(std::make_unique<BandInput>(participant, topic_of(config.band), band_of(config.band),
                                           config.deadline)),
      infrared_(config.band == BandChoice::automatic || config.band == BandChoice::both
                    ? std::make_unique<BandInput>(participant,
                                                  transport::topics::kRectifiedInfrared,
                                                  BAND_INFRARED, config.deadline)
                    : nullptr),
      detections_in_(participant, transport::topics::kDetections, transport::event_topic_qos()),
      out_(participant, transport::topics::kMatches, transport::event_topic_qos()),
      health_(participant, service_name, [this] {
        std::vector<transport::TopicCountersSnapshot> counters{
            primary_->reader.counters(), detections_in_.counters(), out_.counters()};
        if (infrared_) counters.push_back(infrared_->reader.counters());
        return counters;
      }) {
  if (config_.frames_kept == 0) throw std::invalid_argument("frames_kept must be at least 1");
  const auto geometry = node::pipeline_geometry(rig, config.grid);
  grid_size_ = geometry.grid.image_size();
  // The largest disparity of either pair for the nearest target searched.
  const auto infrared = node::registered_infrared_geometry(rig, geometry);
  const range::RangingGeometry widest{
      geometry.grid, std::max(geometry.baseline_m, infrared.baseline_m), geometry.T_ref_left_rect};
  config_.match.min_disparity_px = 0.0;
  config_.match.max_disparity_px = range::max_disparity_for(widest, config.min_distance_m);
  health_.set_state(HEALTH_STARTING, "waiting for frames and detections");
}

MatchNode::~MatchNode() = default;

void MatchNode::take_frames(BandInput& input) {
  auto frames = input.reader.take();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const GridStereoFrame& frame = frames[i];
    try {
      const std::uint64_t last_seq = input.order.last_seq();
      switch (input.order.check(frame.seq(), frame.capture_time_ns())) {
        case node::FrameOrder::Verdict::repeated:
          continue;
        case node::FrameOrder::Verdict::stale:
          throw node::FrameError("frame " + std::to_string(frame.seq()) +
                                 " captured before frame " + std::to_string(last_seq) +
                                 ": out of order, dropped");
        case node::FrameOrder::Verdict::restarted:
          // The writer restarted and counts from the start again: the pairs kept are of the
          // old count, which new detections must not meet.
          input.pairs.clear();
          break;
        case node::FrameOrder::Verdict::next:
          break;
      }
      if (frame.eyes() == EYES_LEFT) {
        throw node::FrameError("frame " + std::to_string(frame.seq()) +
                               " carries the left eye only (thermovis-rectify-fuse fuses the "
                               "right eye with --fused-eyes both)");
      }
      Pair pair;
      pair.seq = frame.seq();
      pair.left = grey_copy(node::view(frame, node::Eye::left, grid_size_));
      pair.right = grey_copy(node::view(frame, node::Eye::right, grid_size_));
      if ((input.band == BAND_INFRARED) != (pair.left.type() == CV_16UC1)) {
        throw node::FrameError("frame " + std::to_string(pair.seq) + ": " +
                               (input.band == BAND_INFRARED ? "expected MONO16 infrared counts"
                                                            : "16-bit pixels in an 8-bit band"));
      }
      if (!frames.still_valid(i)) {
        // The writer reused the sample while it was copied: a torn copy, dropped (not bad
        // input; detections for it are answered "without frame").
        ++stats_.overwritten;
        continue;
      }
      input.pairs.push_back(std::move(pair));
      while (input.pairs.size() > config_.frames_kept) input.pairs.pop_front();
    } catch (const std::exception& e) {
      ++stats_.bad;
      health_.bad_input(input.reader.topic_name() + ": " + e.what());
    }
  }
}

const MatchNode::Pair* MatchNode::find(BandInput& input, std::uint64_t seq) {
  // Detections can arrive before the frame they belong to (the detector needs only the
  // infrared pair, published first): wait for it a little, never for a frame already passed.
  const auto until = std::chrono::steady_clock::now() + kFrameWait;
  while (true) {
    for (const Pair& p : input.pairs)
      if (p.seq == seq) return &p;
    if (!input.pairs.empty() && input.pairs.back().seq > seq) return nullptr;
    if (std::chrono::steady_clock::now() >= until || node::stop_requested()) return nullptr;
    input.reader.wait_for_data(std::chrono::milliseconds(2));
    take_frames(input);
  }
}

void MatchNode::run() {
  while (!node::stop_requested()) {
    health_.tick();
    const bool detections_waiting = detections_in_.wait_for_data(std::chrono::milliseconds(50));
    take_frames(*primary_);
    if (infrared_) take_frames(*infrared_);
    if (!detections_waiting) continue;
    auto arrays = detections_in_.take();
    for (std::size_t i = 0; i < arrays.size(); ++i) answer(arrays[i]);
  }
  health_.set_state(HEALTH_STOPPING, "answered " + std::to_string(stats_.processed));
}

match::MatchResult MatchNode::match_on(Band band, const Pair& pair, const cv::Rect& box) const {
  if (band != BAND_INFRARED) return match::match_box(pair.left, pair.right, box, config_.match);
  // Infrared counts: the box's search region (the same in both eyes, so disparities are kept)
  // stretched to 8 bits, matched there, and the points moved back to the whole image.
  const int pad = config_.match.patch_radius + 8;
  const int reach = static_cast<int>(std::ceil(config_.match.max_disparity_px));
  const cv::Rect region = cv::Rect(box.x - reach - pad, box.y - pad, box.width + reach + 2 * pad,
                                   box.height + 2 * pad) &
                          cv::Rect(0, 0, pair.left.cols, pair.left.rows);
  if (region.empty()) return {};
  cv::Mat left8, right8;
  stretch_counts(pair.left(region), pair.right(region), left8, right8);
  match::MatchResult result = match::match_box(left8, right8, box - region.tl(), config_.match);
  const Eigen::Vector2d offset(region.x, region.y);
  for (auto& c : result.matches) {
    c.left += offset;
    c.right += offset;
  }
  result.box += region.tl();
  return result;
}

TargetMatch MatchNode::target_match(const Detection& detection, Band band,
                                    match::MatchResult result) {
  if (result.matches.size() > MAX_POINT_MATCHES) {
    // Keep the best-correlated points the message has room for.
    std::partial_sort(result.matches.begin(), result.matches.begin() + MAX_POINT_MATCHES,
                      result.matches.end(),
                      [](const auto& a, const auto& b) { return a.score > b.score; });
    result.matches.resize(MAX_POINT_MATCHES);
  }
  TargetMatch target;
  target.target_id(detection.target_id());
  target.label(detection.label());
  target.box(detection.box());
  target.band(band);
  for (const match::Correspondence& c : result.matches) {
    PointMatch point;
    point.left_x(static_cast<float>(c.left.x()));
    point.left_y(static_cast<float>(c.left.y()));
    point.right_x(static_cast<float>(c.right.x()));
    point.right_y(static_cast<float>(c.right.y()));
    target.points().push_back(point);
  }
  stats_.points += target.points().size();
  return target;
}

void MatchNode::answer(const DetectionArray& detections) {
  const std::int64_t start_ns = transport::now_ns();
  const std::uint64_t seq = detections.frame_seq();
  const Pair* primary = find(*primary_, seq);
  const Pair* infrared = infrared_ ? find(*infrared_, seq) : nullptr;
  if (primary == nullptr && infrared == nullptr) {
    ++stats_.no_frame;
    return;
  }
  MatchArray out;
  out.frame_seq(seq);
  out.capture_time_ns(detections.capture_time_ns());
  try {
    // Both bands: the infrared entries follow all visible ones, so a full array loses only
    // infrared entries.
    std::vector<std::pair<const Detection*, cv::Rect>> infrared_boxes;
    for (const Detection& detection : detections.detections()) {
      const cv::Rect box = node::to_rect(detection.box());
      if (box.empty()) {
        throw std::invalid_argument("detection " + std::to_string(detection.target_id()) +
                                    " of frame " + std::to_string(seq) +
                                    ": box with no area or a non-finite field");
      }
      Band band = primary_->band;
      match::MatchResult result;
      if (primary != nullptr) result = match_on(band, *primary, box);
      if (config_.band == BandChoice::both) {
        if (infrared != nullptr) infrared_boxes.emplace_back(&detection, box);
        if (primary == nullptr) continue;
      } else if (infrared != nullptr &&
                 static_cast<int>(result.matches.size()) < config_.min_visible_points) {
        match::MatchResult ir = match_on(BAND_INFRARED, *infrared, box);
        if (ir.matches.size() > result.matches.size()) {
          result = std::move(ir);
          band = BAND_INFRARED;
          ++stats_.infrared_targets;
        }
      }
      out.targets().push_back(target_match(detection, band, std::move(result)));
    }
    for (const auto& [detection, box] : infrared_boxes) {
      if (out.targets().size() >= MAX_TARGETS) {
        ++stats_.infrared_left_out;
        continue;
      }
      out.targets().push_back(
          target_match(*detection, BAND_INFRARED, match_on(BAND_INFRARED, *infrared, box)));
      ++stats_.infrared_targets;
    }
  } catch (const std::exception& e) {
    ++stats_.bad;
    health_.bad_input(std::string(transport::topics::kDetections) + ": " + e.what());
    return;
  }
  out.stamps(detections.stamps());
  transport::append_stamp(out.stamps(), STAGE_MATCH, start_ns, transport::now_ns());
  out_.write(out);
  ++stats_.processed;
  health_.frame_processed();
}

}  // namespace thermovis::match_service
