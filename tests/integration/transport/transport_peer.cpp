// The other process of the transport integration tests and of the thermovis-tap test:
//   transport_peer publish-frames   --domain D --count N --period-ms P --deadline-ms T --result F
//   transport_peer subscribe-frames --domain D --count N --deadline-ms T --result F
//   transport_peer publish-ranges   --domain D --count N --period-ms P [--readers R]
// Frames are VisibleStereoFrame (2 x 6.2 MB) filled with frame_pattern.hpp and sent through the
// loaned data-sharing path. Each frame process writes a JSON result file (where its samples
// lived in memory, integrity, deadline counters) that the test reads after both exited.
// Participants use the loopback profile (deploy/dds/loopback.xml).
#include <chrono>
#include <csignal>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include <CLI/CLI.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <nlohmann/json.hpp>

#include "frame_pattern.hpp"
#include "range_pattern.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/participant.hpp"
#include "thermovis/transport/reader.hpp"
#include "thermovis/transport/shared_memory.hpp"
#include "thermovis/transport/stamps.hpp"
#include "thermovis/transport/topics.hpp"
#include "thermovis/transport/writer.hpp"

namespace {

using namespace std::chrono_literals;
namespace tt = thermovis::transport;

constexpr const char* kFrameTopic = "thermovis/test/frames";

struct Options {
  int domain = 0;
  int count = 10;
  int period_ms = 20;
  int deadline_ms = 20;
  int readers = 1;
  int timeout_s = 60;
  std::string result;
};

nlohmann::json where(const void* address) {
  const auto mapping = tt::mapping_of(address);
  if (!mapping) return {{"path", ""}, {"offset", 0}};
  return {{"path", mapping->path}, {"offset", tt::file_offset(*mapping, address)}};
}

nlohmann::json counters_json(const tt::TopicCountersSnapshot& c) {
  return {{"samples", c.samples},
          {"offered_deadline_missed", c.offered_deadline_missed},
          {"requested_deadline_missed", c.requested_deadline_missed}};
}

void write_result(const std::string& path, const nlohmann::json& result) {
  std::ofstream out(path);
  out << result.dump(1) << "\n";
  if (!out) throw std::runtime_error("cannot write result file " + path);
}

tt::ParticipantConfig loopback(int domain, const std::string& name) {
  return {domain, {}, tt::kLoopbackProfile, name};
}

// Discovery is not symmetric: the writer may match the reader before the reader matches the
// writer, and a VOLATILE reader drops samples of a writer it does not know yet. So the
// subscriber announces on a small TRANSIENT_LOCAL topic once its reader has matched, and the
// publisher starts only after that announcement.
constexpr const char* kReadyTopic = "thermovis/test/ready";

void wait_for_ready_subscriber(tt::Participant& participant, int timeout_s) {
  tt::Reader<thermovis::Health> ready(participant, kReadyTopic, tt::state_topic_qos());
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s);
  while (std::chrono::steady_clock::now() < give_up) {
    if (ready.wait_for_data(100ms) && !ready.take().empty()) return;
  }
  throw std::runtime_error("the subscriber did not announce itself within the timeout");
}

// Returns the announcing writer: it must live on (its TRANSIENT_LOCAL sample with it) while
// frames are read; waiting here for the publisher's acknowledgement could take a heartbeat
// period, long enough to miss the first frames.
std::unique_ptr<tt::Writer<thermovis::Health>> announce_ready(tt::Participant& participant) {
  auto ready = std::make_unique<tt::Writer<thermovis::Health>>(participant, kReadyTopic,
                                                               tt::state_topic_qos());
  thermovis::Health health;
  health.service("transport_peer subscriber");
  health.state(thermovis::HEALTH_OK);
  ready->write(health);
  return ready;
}

int publish_frames(const Options& o) {
  tt::Participant participant(loopback(o.domain, "transport_peer publisher"));
  tt::Writer<thermovis::VisibleStereoFrame> writer(
      participant, kFrameTopic, tt::frame_topic_qos(std::chrono::milliseconds(o.deadline_ms)));
  wait_for_ready_subscriber(participant, o.timeout_s);
  if (!writer.wait_for_readers(1, std::chrono::seconds(o.timeout_s))) {
    throw std::runtime_error("no reader matched within the timeout");
  }
  nlohmann::json frames = nlohmann::json::array();
  auto next = std::chrono::steady_clock::now();
  for (int i = 0; i < o.count; ++i) {
    std::this_thread::sleep_until(next);
    next += std::chrono::milliseconds(o.period_ms);
    auto frame = writer.loan();
    const auto seq = static_cast<std::uint64_t>(i + 1);
    frame->seq(seq);
    frame->capture_time_ns(tt::now_ns());
    frame->pixel_format(thermovis::PIXEL_FORMAT_BGR8);
    frame->width(thermovis::VISIBLE_WIDTH);
    frame->height(thermovis::VISIBLE_HEIGHT);
    frame->step(thermovis::VISIBLE_WIDTH * 3);
    tt::clear_stamps(frame->stamps());
    thermovis::test::fill_pattern(frame->left().data(), frame->left().size(), seq, 0);
    thermovis::test::fill_pattern(frame->right().data(), frame->right().size(), seq, 1);
    frames.push_back({{"seq", seq}, {"left", where(frame->left().data())}});
    writer.publish(std::move(frame));
  }
  // Stay until the reader has everything it needs (it leaves after its last frame).
  writer.native().wait_for_acknowledgments(eprosima::fastrtps::Duration_t(o.timeout_s, 0));
  const auto deadline_end = std::chrono::steady_clock::now() + std::chrono::seconds(o.timeout_s);
  while (writer.counters().matched > 0 && std::chrono::steady_clock::now() < deadline_end) {
    std::this_thread::sleep_for(10ms);
  }
  write_result(o.result, {{"frames", frames},
                          {"counters", counters_json(writer.counters())},
                          {"segments", tt::mapped_data_sharing_segments()}});
  return 0;
}

int subscribe_frames(const Options& o) {
  tt::Participant participant(loopback(o.domain, "transport_peer subscriber"));
  tt::Reader<thermovis::VisibleStereoFrame> reader(
      participant, kFrameTopic, tt::frame_topic_qos(std::chrono::milliseconds(o.deadline_ms)));
  if (!reader.wait_for_writers(1, std::chrono::seconds(o.timeout_s))) {
    throw std::runtime_error("no writer matched within the timeout");
  }
  const auto ready = announce_ready(participant);
  nlohmann::json frames = nlohmann::json::array();
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(o.timeout_s);
  int received = 0;
  std::uint64_t last_seq = 0;  // stop at the last frame even if some were lost
  while (last_seq < static_cast<std::uint64_t>(o.count) &&
         std::chrono::steady_clock::now() < give_up) {
    if (!reader.wait_for_data(100ms)) continue;
    auto samples = reader.take();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const auto& frame = samples[i];
      const std::size_t errors = thermovis::test::pattern_errors(
                                     frame.left().data(), frame.left().size(), frame.seq(), 0) +
                                 thermovis::test::pattern_errors(
                                     frame.right().data(), frame.right().size(), frame.seq(), 1);
      frames.push_back({{"seq", frame.seq()},
                        {"pattern_errors", errors},
                        {"width", frame.width()},
                        {"height", frame.height()},
                        {"pixel_format", frame.pixel_format()},
                        {"latency_ns", tt::now_ns() - frame.capture_time_ns()},
                        {"still_valid", samples.still_valid(i)},
                        {"left", where(frame.left().data())}});
      ++received;
      last_seq = frame.seq();
    }
  }
  write_result(o.result, {{"frames", frames},
                          {"counters", counters_json(reader.counters())},
                          {"segments", tt::mapped_data_sharing_segments()}});
  return received == o.count ? 0 : 3;
}

thermovis::RangeArray range_sample(std::uint64_t seq) {
  thermovis::RangeArray ranges;
  ranges.frame_seq(seq);
  ranges.capture_time_ns(thermovis::test::expected_capture_time_ns(seq));
  for (int t = 0; t < thermovis::test::kTargetsPerFrame; ++t) {
    const auto e = thermovis::test::expected_target(seq, t);
    thermovis::TargetRange target;
    target.target_id(e.target_id);
    target.label(e.label);
    target.distance_m(e.distance_m);
    target.sigma_m(e.sigma_m);
    target.x_m(e.x_m);
    target.y_m(e.y_m);
    target.z_m(e.z_m);
    target.box().x(e.box_x);
    target.box().y(e.box_y);
    target.box().width(e.box_width);
    target.box().height(e.box_height);
    target.point_count(e.point_count);
    ranges.targets().push_back(target);
  }
  return ranges;
}

// Publishes RangeArray samples every period until `count` were sent or every reader has left
// (thermovis-tap exits after the samples it was asked for).
int publish_ranges(const Options& o) {
  tt::Participant participant(loopback(o.domain, "transport_peer ranges"));
  tt::Writer<thermovis::RangeArray> writer(participant, tt::topics::kRanges, tt::event_topic_qos());
  if (!writer.wait_for_readers(static_cast<std::uint32_t>(o.readers),
                               std::chrono::seconds(o.timeout_s))) {
    throw std::runtime_error("no reader of thermovis/ranges matched within the timeout");
  }
  for (int i = 0; i < o.count && writer.counters().matched > 0; ++i) {
    writer.write(range_sample(static_cast<std::uint64_t>(i + 1)));
    std::this_thread::sleep_for(std::chrono::milliseconds(o.period_ms));
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"thermovis transport test peer"};
  app.require_subcommand(1);
  Options o;
  for (const char* name : {"publish-frames", "subscribe-frames", "publish-ranges"}) {
    auto* sub = app.add_subcommand(name);
    sub->add_option("--domain", o.domain)->required();
    sub->add_option("--count", o.count);
    sub->add_option("--period-ms", o.period_ms);
    sub->add_option("--deadline-ms", o.deadline_ms);
    sub->add_option("--readers", o.readers);
    sub->add_option("--timeout-s", o.timeout_s);
    sub->add_option("--result", o.result);
  }
  CLI11_PARSE(app, argc, argv);
  try {
    const std::string mode = app.get_subcommands().front()->get_name();
    if (mode == "publish-frames") return publish_frames(o);
    if (mode == "subscribe-frames") return subscribe_frames(o);
    return publish_ranges(o);
  } catch (const std::exception& e) {
    eprosima::fastdds::dds::Log::Flush();  // the middleware logs asynchronously
    std::cerr << "transport_peer: " << e.what() << "\n";
    return 2;
  }
}
