#include "thermovis/transport/health.hpp"

#include <stdexcept>

#include "thermovis/transport/clock.hpp"

namespace thermovis::transport {

thermovis::Health make_health(const ServiceHealth& health) {
  if (health.topics.size() > thermovis::MAX_HEALTH_TOPICS) {
    throw std::invalid_argument("health of " + health.service + " lists " +
                                std::to_string(health.topics.size()) + " topics, at most " +
                                std::to_string(thermovis::MAX_HEALTH_TOPICS));
  }
  thermovis::Health out;
  out.service(health.service);
  out.state(health.state);
  out.time_ns(now_ns());
  out.frames_processed(health.frames_processed);
  out.errors(health.errors);
  out.message(health.message);
  for (const auto& counters : health.topics) {
    thermovis::TopicHealth topic;
    topic.topic(counters.topic);
    topic.samples(counters.samples);
    topic.requested_deadline_missed(counters.requested_deadline_missed);
    topic.offered_deadline_missed(counters.offered_deadline_missed);
    out.topics().push_back(topic);
  }
  return out;
}

}  // namespace thermovis::transport
