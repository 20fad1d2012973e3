#pragma once
// Building the Health message a service publishes on thermovis/health from its state and the
// counters of its writers and readers (deadline misses per topic).
#include <cstdint>
#include <string>
#include <vector>

#include "thermovis/healthPubSubTypes.h"
#include "thermovis/transport/counters.hpp"

namespace thermovis::transport {

struct ServiceHealth {
  std::string service;  // e.g. "thermovis-range"
  thermovis::HealthState state = thermovis::HEALTH_STARTING;
  std::uint64_t frames_processed = 0;
  std::uint32_t errors = 0;
  std::string message;                        // last error or state change
  std::vector<TopicCountersSnapshot> topics;  // from Writer/Reader::counters()
};

// Strings longer than their IDL bound are cut; more than MAX_HEALTH_TOPICS topics throw
// std::invalid_argument. time_ns is set to now (clock.hpp).
thermovis::Health make_health(const ServiceHealth& health);

}  // namespace thermovis::transport
