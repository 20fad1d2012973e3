#include "bridge_node.hpp"

#include <optional>
#include <thread>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/qos.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"

namespace thermovis::bridge {

BridgeNode::BridgeNode(transport::Participant& participant, std::unique_ptr<FrameSource> source,
                       const BridgeConfig& config, const std::string& service_name)
    : source_(std::move(source)),
      config_(config),
      visible_(participant, transport::topics::kVisibleFrames,
               transport::frame_topic_qos(config.deadline, config.depth, config.max_readers)),
      infrared_(participant, transport::topics::kInfraredFrames,
                transport::frame_topic_qos(config.deadline, config.depth, config.max_readers)),
      health_(participant, service_name, [this] {
        return std::vector<transport::TopicCountersSnapshot>{visible_.counters(),
                                                             infrared_.counters()};
      }) {
  if (!(config_.rate_hz > 0.0)) throw std::invalid_argument("bridge: rate must be positive");
  health_.set_state(HEALTH_STARTING, "source " + source_->name());
}

bool BridgeNode::publish_capture(std::int64_t index) {
  std::int64_t capture_ns = transport::now_ns();
  std::optional<transport::Loan<VisibleStereoFrame>> vis;
  std::optional<transport::Loan<InfraredStereoFrame>> ir;
  try {
    vis.emplace(visible_.loan());
    ir.emplace(infrared_.loan());
  } catch (const std::exception& e) {
    // Every sample is held by readers: drop this capture rather than wait for them.
    ++stats_.dropped;
    health_.bad_input(std::string("capture dropped: ") + e.what());
    return true;
  }
  sim::FrameSet images;
  images[sim::Slot::visible_left] = node::prepare(**vis, node::Eye::left, source_->visible_size());
  images[sim::Slot::visible_right] =
      node::prepare(**vis, node::Eye::right, source_->visible_size());
  images[sim::Slot::infrared_left] = node::prepare(**ir, node::Eye::left, source_->infrared_size());
  images[sim::Slot::infrared_right] =
      node::prepare(**ir, node::Eye::right, source_->infrared_size());
  try {
    if (!source_->fill(index, images)) return false;
  } catch (const std::exception& e) {
    ++stats_.bad;
    health_.bad_input("capture " + std::to_string(index) + ": " + e.what());
    return true;
  }
  // A source that knows when its capture was exposed (a device) sets the pipeline's time zero.
  if (const auto exposed_ns = source_->capture_time_ns()) capture_ns = *exposed_ns;
  const std::int64_t done_ns = transport::now_ns();
  (*vis)->seq(static_cast<std::uint64_t>(index));
  (*vis)->capture_time_ns(capture_ns);
  (*vis)->stamps(PipelineStamps{});
  transport::append_stamp((*vis)->stamps(), STAGE_BRIDGE, capture_ns, done_ns);
  (*ir)->seq(static_cast<std::uint64_t>(index));
  (*ir)->capture_time_ns(capture_ns);
  (*ir)->stamps(PipelineStamps{});
  transport::append_stamp((*ir)->stamps(), STAGE_BRIDGE, capture_ns, done_ns);
  infrared_.publish(std::move(*ir));
  visible_.publish(std::move(*vis));
  ++stats_.published;
  health_.frame_processed();
  return true;
}

void BridgeNode::report_preparing(std::int64_t index) {
  // Twice a second at 50 Hz, and once when it ends: each is a health sample of its own.
  if (!preparing_ || index % 25 != 0) return;
  const std::string what = source_->preparing();
  preparing_ = !what.empty();
  health_.set_message(preparing_ ? std::string(node::kSourcePreparing) + what : "processing");
}

void BridgeNode::run() {
  using Clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / config_.rate_hz));
  // A self-paced source (a device) waits for its own captures inside fill(): no pacing here.
  const bool paced = !source_->self_paced();
  auto next = Clock::now();
  for (std::int64_t index = 0; !node::stop_requested(); ++index) {
    if (config_.frames > 0 && index >= config_.frames) break;
    if (paced) std::this_thread::sleep_until(next);
    const std::uint64_t dropped_before = stats_.dropped;
    if (!publish_capture(index)) break;
    report_preparing(index);
    health_.tick();
    if (!paced) {
      // A dropped capture never reached the source's wait: give readers a moment to return a
      // sample instead of spinning.
      if (stats_.dropped != dropped_before)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    // The first capture also touches the writers' fresh sample pools (page faults over the
    // shared segment, tens of ms for 6 MB frames): time starts after it, not before.
    if (index == 0) next = Clock::now();
    next += period;
    // Fell behind by more than a period (a slow source or a busy machine): skip the captures
    // that are already late rather than bursting them out.
    const auto now = Clock::now();
    while (next + period < now) {
      next += period;
      ++index;
      ++stats_.dropped;
    }
  }
  stats_.source_skipped = source_->skipped();
  health_.set_state(HEALTH_STOPPING, "published " + std::to_string(stats_.published) +
                                         ", dropped " + std::to_string(stats_.dropped) +
                                         ", source skipped " +
                                         std::to_string(stats_.source_skipped));
}

}  // namespace thermovis::bridge
