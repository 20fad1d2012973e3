// thermovis-tap TOPIC [--domain N] [--type T] [--record FILE] [--count N]
// thermovis-tap --publish TOPIC --from FILE|- [--domain N] [--wait-readers N]
// Prints each sample of TOPIC as a JSON line (Cyclone DDS), or publishes JSON lines on TOPIC.
// Network settings come from the standard CYCLONEDDS_URI (deploy/dds/cyclonedds-loopback.xml keeps
// it on 127.0.0.1).
#include <atomic>
#include <csignal>
#include <fstream>
#include <iostream>

#include <CLI/CLI.hpp>

#include "tap.hpp"

namespace {
std::atomic<bool> stop_requested{false};
void on_signal(int) { stop_requested = true; }
}  // namespace

int main(int argc, char** argv) {
  thermovis::tap::TapOptions options;
  CLI::App app{"Print the samples of a thermovis DDS topic as JSON lines (Cyclone DDS client)"};
  std::string topics;
  for (const auto& t : thermovis::tap::known_topics()) topics += (topics.empty() ? "" : ", ") + t;
  std::string publish_topic, from;
  thermovis::tap::PublishOptions publish;
  auto* topic_option = app.add_option("topic", options.topic, "Topic name (" + topics + ")");
  app.add_option("--publish", publish_topic,
                 "Publish instead: one sample per JSON line of --from on this topic "
                 "(thermovis/detections: an external detector)");
  app.add_option("--from", from, "--publish: JSON lines file, or - for standard input");
  app.add_option("--wait-readers", publish.wait_readers,
                 "--publish: readers to wait for before the first sample")
      ->capture_default_str();
  app.add_option("--domain", options.domain, "DDS domain id")->check(CLI::Range(0, 232));
  app.add_option("--type", options.type, "IDL type of the topic when it is not a pipeline topic");
  app.add_option("--record", options.record, "Also write the JSON lines to this file");
  app.add_option("--count", options.count,
                 "Exit after this many samples (default: run until "
                 "SIGINT/SIGTERM)");
  CLI11_PARSE(app, argc, argv);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    if (!publish_topic.empty()) {
      if (from.empty()) throw std::runtime_error("--publish needs --from FILE (or - for stdin)");
      publish.topic = publish_topic;
      publish.domain = options.domain;
      if (from != "-") publish.source = from;
      std::ifstream file;
      if (from != "-") {
        file.open(from);
        if (!file) throw std::runtime_error("cannot read " + from);
      }
      const auto n = thermovis::tap::run_publisher(publish, stop_requested,
                                                   from == "-" ? std::cin : file, std::cerr);
      std::cerr << "thermovis-tap: published " << n << " samples on " << publish.topic << "\n";
      return 0;
    }
    if (topic_option->count() == 0 || !from.empty()) {
      throw std::runtime_error("give a TOPIC to print, or --publish TOPIC --from FILE");
    }
    thermovis::tap::run_tap(options, stop_requested, std::cout);
  } catch (const std::exception& e) {
    std::cerr << "thermovis-tap: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
