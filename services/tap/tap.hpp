#pragma once
// thermovis-tap: a Cyclone DDS (C API) client built from the same IDL as the pipeline (idlc at
// build time). It prints every sample of one topic as a JSON line, proving that an application
// of another DDS vendor can read the pipeline's topics; with --publish it writes JSON lines of
// the same format onto a topic (an external detector feeding thermovis/detections).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

namespace thermovis::tap {

struct TapOptions {
  std::string topic = "thermovis/ranges";
  std::string type;  // IDL type name; empty: the pipeline type of `topic`
  std::uint32_t domain = 0;
  std::filesystem::path record;  // also write the JSON lines here ("" = no)
  std::uint64_t count = 0;       // stop after this many samples (0 = until stopped)
};

struct PublishOptions {
  std::string topic = "thermovis/detections";
  std::uint32_t domain = 0;
  std::uint32_t wait_readers = 1;  // readers to wait for before the first sample (0: none)
  double wait_s = 30.0;            // how long to wait for them
  std::string source = "stdin";    // what the JSON lines are read from, for errors (a file name)
};

// Topics --publish can write (their types' JSON is the one run_tap prints).
std::vector<std::string> publishable_topics();

// Publishes one sample per JSON line read from `in` (RELIABLE, like the pipeline's writers)
// until the end of `in` or `stop`, then waits until the readers have acknowledged every sample.
// A line that is not a valid sample is reported on `log` with the source, its line number, the
// entry and the field at fault, and skipped. Returns the number of samples published. Throws
// std::runtime_error for a topic that cannot be published, no reader within wait_s, or a DDS error.
std::uint64_t run_publisher(const PublishOptions& options, const std::atomic<bool>& stop,
                            std::istream& in, std::ostream& log);

// Topic names with a known type, for --help and error messages.
std::vector<std::string> known_topics();
// IDL type names the tap can decode.
std::vector<std::string> known_types();

// Subscribes and writes one JSON line per sample to `out` (and the record file) until `count`
// samples or `stop` becomes true. Returns the number of samples. Throws std::runtime_error
// for an unknown topic/type, an unwritable record file or a DDS error (with its text).
std::uint64_t run_tap(const TapOptions& options, const std::atomic<bool>& stop, std::ostream& out);

}  // namespace thermovis::tap
