// thermovis record: the topics of a running pipeline into an MCAP file (Foxglove, ROS 2 tools,
// `thermovis replay`). Each sample is stored as the CDR bytes DDS carried, with the time it was
// received (log time) and the time its writer published it.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
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
using tv::cli::RecordableTopic;
using tv::cli::TappedSample;

struct Options {
  tv::node::CommonOptions common;
  std::filesystem::path out;
  std::string topics;
  double seconds = 0.0;
  std::string compression = "zstd";
  int zstd_level = 1;
  double buffer_mb = 1024.0;
  double wait_s = 10.0;
  bool json = false;
};

const std::vector<std::string>& default_topics() {
  namespace t = tv::transport::topics;
  static const std::vector<std::string> names{t::kVisibleFrames, t::kInfraredFrames, t::kDetections,
                                              t::kMatches,       t::kRanges,         t::kTiming};
  return names;
}

struct TopicCount {
  std::uint64_t recorded = 0;
  std::uint64_t missed = 0;   // published, but overwritten in the reader before it took them
  std::uint64_t dropped = 0;  // taken, but the write buffer was full (the disk fell behind)
  std::uint64_t bytes = 0;
};

// Samples on their way from the DDS threads to the file, bounded in bytes.
class SampleQueue {
 public:
  struct Item {
    std::uint16_t channel;
    std::uint64_t log_ns;
    TappedSample sample;
  };
  explicit SampleQueue(std::size_t max_bytes) : max_bytes_(max_bytes) {}

  // False when the sample does not fit (dropped).
  bool push(std::uint16_t channel, TappedSample&& sample) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (bytes_ + sample.cdr.size() > max_bytes_ && !items_.empty()) return false;
    bytes_ += sample.cdr.size();
    // The log time is taken under the lock: the file's messages are in log-time order.
    items_.push_back(
        {channel, static_cast<std::uint64_t>(tv::transport::now_ns()), std::move(sample)});
    ready_.notify_one();
    return true;
  }
  std::optional<Item> pop(std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!ready_.wait_for(lock, timeout, [&] { return !items_.empty(); })) return std::nullopt;
    Item item = std::move(items_.front());
    items_.pop_front();
    bytes_ -= item.sample.cdr.size();
    return item;
  }

 private:
  std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Item> items_;
  std::size_t bytes_ = 0;
  std::size_t max_bytes_;
};

int run_record(const Options& opt) {
  tv::node::install_stop_handlers();
  const auto topics = tv::cli::parse_topic_list(opt.topics, default_topics());
  tv::record::McapWriterOptions wo;
  wo.library = "thermovis record";
  wo.compression = opt.compression == "zstd" ? tv::record::McapCompression::zstd
                                             : tv::record::McapCompression::none;
  wo.zstd_level = opt.zstd_level;
  tv::record::McapWriter writer(opt.out, wo);
  auto participant = tv::node::make_participant(opt.common);

  std::map<std::string, std::uint16_t> schema_of_type;
  std::vector<std::uint16_t> channels;
  std::vector<std::unique_ptr<tv::cli::TopicTap>> taps;
  for (const RecordableTopic& topic : topics) {
    auto schema = schema_of_type.find(topic.type_name);
    if (schema == schema_of_type.end()) {
      schema = schema_of_type
                   .emplace(topic.type_name, writer.add_schema(topic.type_name, "omgidl",
                                                               tv::cli::schema_text(topic)))
                   .first;
    }
    channels.push_back(writer.add_channel(schema->second, topic.topic, "cdr"));
    taps.push_back(tv::cli::make_tap(*participant, topic));
  }

  // The writers first: --seconds counts from when every topic has one (on a loaded machine
  // discovery can take seconds), so a timed recording is not spent waiting for them.
  const auto wait_until = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<std::int64_t>(opt.wait_s * 1000));
  for (std::size_t i = 0; i < taps.size(); ++i) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        wait_until - std::chrono::steady_clock::now());
    if (!taps[i]->wait_for_writers(std::max(left, std::chrono::milliseconds(0))) &&
        !tv::node::stop_requested())
      std::cerr << "thermovis record: no writer on " << topics[i].topic << " after " << opt.wait_s
                << " s; recording anyway" << std::endl;
  }

  SampleQueue queue(static_cast<std::size_t>(opt.buffer_mb * 1024 * 1024));
  std::vector<TopicCount> counts(topics.size());
  std::mutex counts_mutex;
  std::atomic<bool> stop_taps{false};
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < taps.size(); ++i) {
    threads.emplace_back([&, i] {
      const auto sink = [&](TappedSample&& sample) {
        const std::uint64_t missed = sample.missed_before;
        const bool queued = queue.push(channels[i], std::move(sample));
        std::lock_guard<std::mutex> lock(counts_mutex);
        counts[i].missed += missed;
        if (!queued) ++counts[i].dropped;
      };
      while (!stop_taps) taps[i]->poll(std::chrono::milliseconds(100), sink);
    });
  }
  const bool json = opt.json;
  if (!json) {
    std::cout << "thermovis record: " << topics.size() << " topics on DDS domain "
              << opt.common.domain << " into " << opt.out.string() << " (Ctrl-C stops)"
              << std::endl;
  }
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::uint64_t payload_bytes = 0;
  const auto write = [&](SampleQueue::Item& item) {
    const auto& s = item.sample;
    writer.write(item.channel, static_cast<std::uint32_t>(s.writer_sequence), item.log_ns,
                 static_cast<std::uint64_t>(s.publish_ns), s.cdr.data(), s.cdr.size());
    payload_bytes += s.cdr.size();
    std::lock_guard<std::mutex> lock(counts_mutex);
    ++counts[item.channel].recorded;
    counts[item.channel].bytes += s.cdr.size();
  };
  while (!tv::node::stop_requested() && (opt.seconds <= 0 || elapsed() < opt.seconds)) {
    if (auto item = queue.pop(std::chrono::milliseconds(100))) write(*item);
  }
  stop_taps = true;
  for (auto& t : threads) t.join();
  while (auto item = queue.pop(std::chrono::milliseconds(0))) write(*item);
  const double seconds = elapsed();
  writer.close();

  const double file_mb = static_cast<double>(std::filesystem::file_size(opt.out)) / 1e6;
  nlohmann::json per_topic = nlohmann::json::object();
  std::uint64_t missed = 0, dropped = 0;
  for (std::size_t i = 0; i < topics.size(); ++i) {
    per_topic[topics[i].topic] = {{"recorded", counts[i].recorded},
                                  {"missed", counts[i].missed},
                                  {"dropped", counts[i].dropped},
                                  {"mb", static_cast<double>(counts[i].bytes) / 1e6}};
    missed += counts[i].missed;
    dropped += counts[i].dropped;
  }
  const nlohmann::json summary{
      {"file", opt.out.string()},
      {"seconds", seconds},
      {"messages", writer.statistics().message_count},
      {"payload_mb", static_cast<double>(payload_bytes) / 1e6},
      {"file_mb", file_mb},
      {"record_mb_per_s", static_cast<double>(payload_bytes) / 1e6 / seconds},
      {"missed", missed},
      {"dropped", dropped},
      {"topics", per_topic}};
  if (json) {
    std::cout << summary.dump() << std::endl;
  } else {
    std::cout << std::fixed << std::setprecision(1) << "recorded " << summary["messages"]
              << " messages in " << seconds << " s: " << summary["payload_mb"].get<double>()
              << " MB of samples (" << summary["record_mb_per_s"].get<double>() << " MB/s), file "
              << file_mb << " MB\n";
    for (std::size_t i = 0; i < topics.size(); ++i) {
      std::cout << "  " << std::left << std::setw(30) << topics[i].topic << std::right
                << std::setw(8) << counts[i].recorded << " recorded" << std::setw(8)
                << counts[i].missed << " missed" << std::setw(8) << counts[i].dropped
                << " dropped\n";
    }
  }
  return 0;
}

THERMOVIS_COMMAND(
    "record", "record pipeline topics into an MCAP file (Foxglove, ROS 2 tools, thermovis replay)",
    [](CLI::App& app) -> thermovis::cli::Runner {
      auto opt = std::make_shared<Options>();
      opt->common.service = "thermovis-record";
      thermovis::node::add_common_options(app, opt->common);
      app.footer(
          "Sizes: a capture is a visible frame (12.4 MB on the wire: the type holds the full "
          "1920x1080 pair) and an infrared frame (3.1 MB), so raw captures at 50 Hz are about "
          "780 MB/s; the small topics are a few kB per frame. zstd level 1 keeps up with a few "
          "captures a second on one core (run the bridge at a lower --rate to record every "
          "capture). Captures the recorder could not take before the next ones replaced them "
          "are counted as missed, samples the disk could not keep up with as dropped: both are "
          "reported at the end.");
      app.add_option("--out", opt->out, "MCAP file to write")->required();
      app.add_option("--topics", opt->topics,
                     "comma-separated topics (default: the raw captures, detections, matches, "
                     "ranges and timing)");
      app.add_option("--seconds", opt->seconds, "stop after this long (0: at SIGINT/SIGTERM)")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      app.add_option("--compression", opt->compression, "chunk compression")
          ->capture_default_str()
          ->check(CLI::IsMember({"zstd", "none"}));
      app.add_option("--zstd-level", opt->zstd_level, "zstd level (1: fastest)")
          ->capture_default_str()
          ->check(CLI::Range(1, 19));
      app.add_option("--buffer-mb", opt->buffer_mb,
                     "samples held in memory while the file catches up, MB; beyond it they are "
                     "dropped and counted")
          ->capture_default_str()
          ->check(CLI::PositiveNumber);
      app.add_option("--wait", opt->wait_s,
                     "wait this long for a writer on every topic before recording starts, s")
          ->capture_default_str()
          ->check(CLI::NonNegativeNumber);
      app.add_flag("--json", opt->json, "print the summary as one JSON object");
      return [opt] { return run_record(*opt); };
    });

}  // namespace
