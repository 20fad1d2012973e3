#pragma once
// thermovis-tap: a Cyclone DDS (C API) subscriber built from the same IDL as the pipeline
// (idlc at build time). It prints every sample of one topic as a JSON line, proving that an
// application of another DDS vendor can read the pipeline's topics.
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

// Topic names with a known type, for --help and error messages.
std::vector<std::string> known_topics();
// IDL type names the tap can decode.
std::vector<std::string> known_types();

// Subscribes and writes one JSON line per sample to `out` (and the record file) until `count`
// samples or `stop` becomes true. Returns the number of samples. Throws std::runtime_error
// for an unknown topic/type, an unwritable record file or a DDS error (with its text).
std::uint64_t run_tap(const TapOptions& options, const std::atomic<bool>& stop, std::ostream& out);

}  // namespace thermovis::tap
