// thermovis-tap TOPIC [--domain N] [--type T] [--record FILE] [--count N]
// Prints each sample of TOPIC as a JSON line (Cyclone DDS). Network settings come from the
// standard CYCLONEDDS_URI (deploy/dds/cyclonedds-loopback.xml keeps it on 127.0.0.1).
#include <atomic>
#include <csignal>
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
  app.add_option("topic", options.topic, "Topic name (" + topics + ")")->required();
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
    thermovis::tap::run_tap(options, stop_requested, std::cout);
  } catch (const std::exception& e) {
    std::cerr << "thermovis-tap: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
