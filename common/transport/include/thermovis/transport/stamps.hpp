#pragma once
// Filling and reading the per-stage stamps (thermovis::PipelineStamps) every message carries.
#include <cstddef>
#include <cstdint>

#include "thermovis/commonPubSubTypes.h"

namespace thermovis::transport {

// Marks every entry unused (a loaned frame's memory is not initialised).
void clear_stamps(thermovis::PipelineStamps& stamps);

// Number of used entries (up to the first unused one).
std::size_t stamp_count(const thermovis::PipelineStamps& stamps);

// Milliseconds from capture_ns to the latest stage end in `stamps` (0 without stamps): the
// capture-to-output latency of the message carrying them.
double latency_ms(const thermovis::PipelineStamps& stamps, std::int64_t capture_ns);

// Appends `stage` that ran from start_ns to end_ns (stamp clock, clock.hpp) in the first unused
// entry; a stage that ends before it starts is recorded with duration 0. When all
// MAX_STAGE_STAMPS entries are used, the last one takes the newest stage (the end of the
// pipeline, which latency is measured to, is never lost) and false is returned.
bool append_stamp(thermovis::PipelineStamps& stamps, thermovis::Stage stage, std::int64_t start_ns,
                  std::int64_t end_ns);

}  // namespace thermovis::transport
