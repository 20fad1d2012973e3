#include "thermovis/transport/stamps.hpp"

#include <algorithm>
#include <limits>

namespace thermovis::transport {

void clear_stamps(thermovis::PipelineStamps& stamps) {
  for (auto& stamp : stamps.stamps()) {
    stamp.stage(thermovis::STAGE_NONE);
    stamp.duration_us(0);
    stamp.end_ns(0);
  }
}

double latency_ms(const thermovis::PipelineStamps& stamps, std::int64_t capture_ns) {
  std::int64_t end_ns = capture_ns;
  for (const auto& stamp : stamps.stamps())
    if (stamp.stage() != thermovis::STAGE_NONE) end_ns = std::max(end_ns, stamp.end_ns());
  return static_cast<double>(end_ns - capture_ns) / 1e6;
}

std::size_t stamp_count(const thermovis::PipelineStamps& stamps) {
  std::size_t count = 0;
  while (count < stamps.stamps().size() &&
         stamps.stamps()[count].stage() != thermovis::STAGE_NONE) {
    ++count;
  }
  return count;
}

bool append_stamp(thermovis::PipelineStamps& stamps, thermovis::Stage stage, std::int64_t start_ns,
                  std::int64_t end_ns) {
  const std::size_t count = stamp_count(stamps);
  const bool free = count < stamps.stamps().size();
  auto& stamp = stamps.stamps()[free ? count : stamps.stamps().size() - 1];
  const std::int64_t duration_us = std::max<std::int64_t>(0, end_ns - start_ns) / 1000;
  stamp.stage(stage);
  stamp.duration_us(static_cast<std::uint32_t>(
      std::min<std::int64_t>(duration_us, std::numeric_limits<std::uint32_t>::max())));
  stamp.end_ns(end_ns);
  return free;
}

}  // namespace thermovis::transport
