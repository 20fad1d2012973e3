#include "match_node.hpp"

#include <algorithm>
#include <stdexcept>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::match_service {
namespace {

// How long a detection array waits for its frame.
constexpr std::chrono::milliseconds kFrameWait{40};

}  // namespace

struct MatchNode::BandInput {
  BandInput(transport::Participant& participant, const char* topic, pipeline::Band band_,
            const std::string& service, std::size_t kept, std::chrono::nanoseconds deadline,
            transport::FrameReader<GridStereoFrame>::BadFrame bad_frame)
      : band(band_),
        reader(participant, topic, transport::frame_topic_qos(deadline, 2, 2),
               std::move(bad_frame)),
        pairs(kept),
        sequence(service, std::string(topic) + " frame") {}
  pipeline::Band band;
  transport::FrameReader<GridStereoFrame> reader;
  node::SeqBuffer<Pair> pairs;
  node::FrameSequence sequence;  // of the frames taken
};

MatchNode::MatchNode(transport::Participant& participant, const MatchConfig& config,
                     const std::string& service_name)
    : config_(config),
      stage_(participant, config.match),
      detections_in_(participant, transport::topics::kDetections, transport::event_topic_qos()),
      out_(participant, transport::topics::kMatches, transport::event_topic_qos()),
      health_(participant, service_name, [this] {
        std::vector<transport::TopicCountersSnapshot> counters{detections_in_.counters(),
                                                               out_.counters(), stage_.counters()};
        for (const auto* input : {primary_.get(), infrared_.get()})
          if (input != nullptr) counters.push_back(input->reader.counters());
        return counters;
      }) {
  if (config_.frames_kept == 0) throw std::invalid_argument("frames_kept must be at least 1");
  const auto bad_frame = node::count_bad_input(stats_.bad, health_);
  const pipeline::BandChoice band = config.match.band;
  if (band != pipeline::BandChoice::infrared) {
    const bool fused = band == pipeline::BandChoice::fused;
    primary_ = std::make_unique<BandInput>(
        participant, fused ? transport::topics::kFused : transport::topics::kRectifiedVisible,
        fused ? pipeline::Band::fused : pipeline::Band::visible, service_name, config.frames_kept,
        config.deadline, bad_frame);
  }
  if (band == pipeline::BandChoice::infrared || band == pipeline::BandChoice::automatic ||
      band == pipeline::BandChoice::both) {
    infrared_ = std::make_unique<BandInput>(participant, transport::topics::kRectifiedInfrared,
                                            pipeline::Band::infrared, service_name,
                                            config.frames_kept, config.deadline, bad_frame);
  }
  health_.set_state(HEALTH_STARTING, "no grid geometry yet (thermovis/geometry)");
}

MatchNode::~MatchNode() = default;

void MatchNode::take_frames(BandInput& input) {
  auto frames = input.reader.take();
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const GridStereoFrame& frame = frames[i];
    try {
      if (!input.sequence.admit(frame.seq(), frame.capture_time_ns(), health_)) continue;
      // The writer restarted and counts from the start again: the pairs kept are of the old
      // count, which new detections must not meet.
      if (input.sequence.last_verdict() == node::FrameOrder::Verdict::restarted) {
        input.pairs.clear();
      }
      if (frame.eyes() == EYES_LEFT) {
        throw node::FrameError("frame " + std::to_string(frame.seq()) +
                               " carries the left eye only (thermovis-rectify-fuse fuses the "
                               "right eye with --fused-eyes both)");
      }
      // The band's frames: the grid, the infrared pair's reduced by its reduction.
      const cv::Size grid = stage_.geometry().image_size(input.band);
      Pair pair;
      pair.left =
          pipeline::MatchStage::stage_grey(node::view(frame, node::Eye::left, grid, stage_.id()));
      pair.right =
          pipeline::MatchStage::stage_grey(node::view(frame, node::Eye::right, grid, stage_.id()));
      if ((input.band == pipeline::Band::infrared) != (pair.left.type() == CV_16UC1)) {
        throw node::FrameError("frame " + std::to_string(frame.seq()) + ": " +
                               (input.band == pipeline::Band::infrared
                                    ? "expected MONO16 infrared counts"
                                    : "16-bit pixels in an 8-bit band"));
      }
      if (!frames.still_valid(i)) {
        // The writer reused the sample while it was copied: a torn copy, dropped (not bad
        // input; detections for it are answered "without frame").
        ++stats_.overwritten;
        continue;
      }
      input.pairs.push(frame.seq(), std::move(pair));
    } catch (const std::exception& e) {
      ++stats_.bad;
      health_.bad_input(input.reader.topic_name() + ": " + e.what());
    }
  }
}

const MatchNode::Pair* MatchNode::find(BandInput& input, std::uint64_t seq) {
  // Detections can arrive before the frame they belong to (the detector needs only the
  // infrared pair, published first): wait for it a little, never for a frame already passed.
  return node::join<Pair>(
      input.pairs, seq, kFrameWait,
      [&](std::chrono::milliseconds wait) {
        input.reader.wait_for_data(wait);
        take_frames(input);
      },
      node::stop_requested);
}

void MatchNode::run() {
  node::wait_for_geometry(stage_, health_, "frames and detections", node::stop_requested);
  while (!node::stop_requested()) {
    health_.tick();
    const bool detections_waiting = detections_in_.wait_for_data(std::chrono::milliseconds(50));
    if (!stage_.refresh(health_)) {
      // No grid yet: nothing can be matched; frames and detections are let go.
      for (auto* input : {primary_.get(), infrared_.get()})
        if (input != nullptr) input->reader.take();
      if (detections_waiting) stats_.no_frame += detections_in_.take().size();
      continue;
    }
    for (auto* input : {primary_.get(), infrared_.get()})
      if (input != nullptr) take_frames(*input);
    if (!detections_waiting) continue;
    auto arrays = detections_in_.take();
    for (std::size_t i = 0; i < arrays.size(); ++i) answer(arrays[i]);
  }
  health_.set_state(HEALTH_STOPPING, "answered " + std::to_string(stats_.processed));
}

TargetMatch MatchNode::target_match(const Detection& detection, pipeline::Band band,
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
  target.band(node::to_message(band));
  for (const match::Correspondence& c : result.matches) {
    PointMatch point;
    point.left_x(static_cast<float>(c.left.x()));
    point.left_y(static_cast<float>(c.left.y()));
    point.right_x(static_cast<float>(c.right.x()));
    point.right_y(static_cast<float>(c.right.y()));
    target.points().push_back(point);
  }
  const match::RegionDisparity& q = result.region;
  target.region().valid(q.ok());
  if (q.ok()) {
    target.region().anchor_x(static_cast<float>(q.anchor.x()));
    target.region().anchor_y(static_cast<float>(q.anchor.y()));
    target.region().disparity_px(static_cast<float>(q.disparity_px));
    target.region().sigma_px(static_cast<float>(q.sigma_px));
    target.region().contour_fraction(static_cast<float>(q.contour_fraction));
    target.region().pixels(static_cast<std::uint32_t>(q.pixels));
  }
  stats_.points += target.points().size();
  if (band == pipeline::Band::infrared) ++stats_.infrared_targets;
  return target;
}

void MatchNode::match_boxes(const DetectionArray& detections, const pipeline::MatchImages& images,
                            std::vector<TargetMatch>& into) {
  std::vector<pipeline::MatchStage::Box> boxes;
  boxes.reserve(detections.detections().size());
  for (const Detection& detection : detections.detections()) {
    const cv::Rect box = node::to_rect(detection.box());
    if (box.empty()) {
      throw std::invalid_argument("detection " + std::to_string(detection.target_id()) +
                                  " of frame " + std::to_string(detections.frame_seq()) +
                                  ": box with no area or a non-finite field");
    }
    boxes.push_back({box, detection.label().to_string()});
  }
  // The boxes in parallel with --threads 2 (the other core is free once the visible pair is
  // rectified), their entries in the detections' order.
  std::vector<std::vector<pipeline::BandMatches>> matched =
      stage_.stage().match_each(images, boxes);
  for (std::size_t i = 0; i < matched.size(); ++i) {
    for (pipeline::BandMatches& band : matched[i]) {
      into.push_back(target_match(detections.detections()[i], band.band, std::move(band.result)));
    }
  }
}

void MatchNode::answer(const DetectionArray& detections) {
  const std::int64_t start_ns = transport::now_ns();
  const std::uint64_t seq = detections.frame_seq();
  // rectify-fuse publishes a capture's infrared pair before its visible pair. With `both` the
  // infrared entries do not depend on the visible ones: they are matched first, while the
  // visible pair is still being rectified, and follow all the others in the array, so a full
  // array loses only them. (`automatic` chooses the infrared pair from the visible result.)
  const bool both = config_.match.band == pipeline::BandChoice::both;
  const Pair* infrared = infrared_ ? find(*infrared_, seq) : nullptr;
  MatchArray out;
  out.frame_seq(seq);
  out.capture_time_ns(detections.capture_time_ns());
  try {
    std::vector<TargetMatch> infrared_entries;
    if (both && infrared != nullptr) {
      pipeline::MatchImages images;
      images.infrared_left = infrared->left;
      images.infrared_right = infrared->right;
      match_boxes(detections, images, infrared_entries);
    }
    const Pair* primary = primary_ ? find(*primary_, seq) : nullptr;
    if (primary == nullptr && infrared == nullptr) {
      ++stats_.no_frame;
      return;
    }
    pipeline::MatchImages images;
    if (primary != nullptr) {
      images.primary_left = primary->left;
      images.primary_right = primary->right;
    }
    if (infrared != nullptr && !both) {
      images.infrared_left = infrared->left;
      images.infrared_right = infrared->right;
    } else if (infrared != nullptr) {
      // The visible regions' silhouettes, as in CapturePipeline.
      images.silhouette_infrared = infrared->left;
    }
    if (!images.primary_left.empty() || !images.infrared_left.empty()) {
      match_boxes(detections, images, out.targets());
    }
    for (TargetMatch& entry : infrared_entries) {
      if (out.targets().size() >= MAX_TARGETS) {
        ++stats_.infrared_left_out;
        continue;
      }
      out.targets().push_back(std::move(entry));
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
