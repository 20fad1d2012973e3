// thermovis replay: plays an MCAP file written by `thermovis record` back onto its topics at the
// recorded pace (from the log times), so a pipeline without its bridge processes the recorded
// captures again. Frames are published into loaned data-sharing samples, as the bridge does.
#include <filesystem>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "command.hpp"
#include "recording.hpp"
#include "thermovis/node/service.hpp"
#include "thermovis/record/mcap.hpp"
#include "thermovis/transport/clock.hpp"
#include "thermovis/transport/topics.hpp"

namespace {

namespace tv = thermovis;

struct Options {
  tv::node::CommonOptions common;
  std::filesystem::path in;
  std::string topics;
  double rate_scale = 1.0;
  bool loop = false;
  bool original_times = false;
  double wait_s = 10.0;
  bool json = false;
};

struct Played {
  std::string topic;
  std::unique_ptr<tv::cli::TopicPlayer> player;
  std::uint64_t published = 0, dropped = 0, bad = 0;
};

int run_replay(const Options& opt) {
  tv::node::install_stop_handlers();
  if (opt.loop && opt.original_times)
    throw std::invalid_argument(
        "--loop needs new capture times (the pipeline drops a capture older than the last one): "
        "drop --original-times");
  tv::record::McapReader reader(opt.in);
  namespace t = tv::transport::topics;
  const auto topics =
      tv::cli::parse_topic_list(opt.topics, {t::kVisibleFrames, t::kInfraredFrames});
  auto participant = tv::node::make_participant(opt.common);
  std::map<std::uint16_t, Played> played;  // by channel id
  for (const auto& topic : topics) {
    const tv::record::McapChannel* channel = reader.channel(topic.topic);
    if (channel == nullptr) {
      std::string present;
      for (const auto& [id, c] : reader.channels()) present += " " + c.topic;
      throw std::invalid_argument(opt.in.string() + " has no channel '" + topic.topic +
                                  "' (it has:" + present + ")");
    }
    const auto schema = reader.schemas().find(channel->schema_id);
    if (channel->message_encoding != "cdr" || schema == reader.schemas().end() ||
        schema->second.name != topic.type_name) {
      throw std::invalid_argument(
          opt.in.string() + ": channel '" + topic.topic + "' holds " + channel->message_encoding +
          " messages of schema '" +
          (schema == reader.schemas().end() ? std::string("none") : schema->second.name) +
          "', not cdr " + topic.type_name);
    }
    played[channel->id] = Played{topic.topic, tv::cli::make_player(*participant, topic)};
  }
  // The pipeline's readers first: frames published before they match are lost.
  for (auto& [id, p] : played) {
    const auto wait = std::chrono::milliseconds(static_cast<std::int64_t>(opt.wait_s * 1000));
    if (!p.player->wait_for_readers(wait) && !tv::node::stop_requested())
      std::cerr << "thermovis replay: no reader on " << p.topic << " after " << opt.wait_s
                << " s; playing anyway" << std::endl;
  }
  if (!opt.json) {
    std::cout << "thermovis replay: " << opt.in.string() << " onto DDS domain " << opt.common.domain
              << " at " << opt.rate_scale << "x" << (opt.loop ? ", looping" : "")
              << " (Ctrl-C stops)" << std::endl;
  }

  using Clock = std::chrono::steady_clock;
  const auto started = Clock::now();
  int passes = 0;
  do {
    std::optional<std::uint64_t> first_log;
    Clock::time_point pass_start;
    std::int64_t shift = 0;
    reader.read_messages([&](const tv::record::McapMessageView& m) {
      if (tv::node::stop_requested()) return false;
      const auto it = played.find(m.channel_id);
      if (it == played.end()) return true;
      if (!first_log) {
        first_log = m.log_time;
        pass_start = Clock::now();
        // Recorded capture times moved to now: latency stamps stay meaningful, and every pass
        // is later than the one before (stages drop a capture older than their last).
        shift = opt.original_times
                    ? 0
                    : tv::transport::now_ns() - static_cast<std::int64_t>(m.log_time);
      }
      const auto due =
          pass_start + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::nanoseconds(m.log_time - *first_log) / opt.rate_scale);
      std::this_thread::sleep_until(due);
      Played& p = it->second;
      try {
        if (p.player->publish(m.data, m.size, shift))
          ++p.published;
        else
          ++p.dropped;
      } catch (const std::runtime_error& e) {
        ++p.bad;
        std::cerr << "thermovis replay: " << e.what() << std::endl;
      }
      return true;
    });
    ++passes;
  } while (opt.loop && !tv::node::stop_requested());
  // Readers take the last samples from the writers' pools before these go away.
  if (!tv::node::stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(500));

  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  nlohmann::json per_topic = nlohmann::json::object();
  for (const auto& [id, p] : played)
    per_topic[p.topic] = {{"published", p.published}, {"dropped", p.dropped}, {"bad", p.bad}};
  const nlohmann::json summary{
      {"file", opt.in.string()}, {"seconds", seconds}, {"passes", passes}, {"topics", per_topic}};
  if (opt.json) {
    std::cout << summary.dump() << std::endl;
  } else {
    std::cout << "replayed " << passes << " pass(es) in " << seconds << " s\n";
    for (const auto& [id, p] : played)
      std::cout << "  " << p.topic << ": " << p.published << " published, " << p.dropped
                << " dropped (no free sample), " << p.bad << " undecodable\n";
  }
  return 0;
}

THERMOVIS_COMMAND(
    "replay", "play an MCAP file from `thermovis record` back onto its topics at the recorded pace",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      opt->common.service = "thermovis-replay";
      thermovis::node::add_common_options(app, opt->common);
      app.footer(
          "Run the pipeline without its bridge (a manifest without the bridge service) and "
          "replay the raw captures into it; the recorded detections, matches and ranges are "
          "for comparison and are not replayed unless listed in --topics.");
      app.add_option("--in", opt->in, "MCAP file to play")->required()->check(CLI::ExistingFile);
      app.add_option("--topics", opt->topics,
                     "comma-separated topics to publish (default: the raw captures, "
                     "thermovis/frames/visible and thermovis/frames/infrared)");
      app.add_option("--rate-scale", opt->rate_scale, "speed: 2 plays twice as fast")
          ->capture_default_str()
          ->check(CLI::Range(0.01, 100.0));
      app.add_flag("--loop", opt->loop, "start again at the end, until SIGINT/SIGTERM");
      app.add_flag("--original-times", opt->original_times,
                   "keep the recorded capture and stage times (default: moved to the present, "
                   "so latencies are measured as live)");
      app.add_option("--wait", opt->wait_s, "wait this long for the pipeline's readers, s")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      app.add_flag("--json", opt->json, "print the summary as one JSON object");
      return [opt] { return run_replay(*opt); };
    });

}  // namespace
