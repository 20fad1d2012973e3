#include "thermovis/transport/bounds.hpp"

#include <stdexcept>
#include <string>

namespace thermovis::transport {

namespace {

void check(std::size_t length, std::uint32_t bound, const char* field) {
  if (length > bound) {
    throw std::invalid_argument(std::string(field) + " has " + std::to_string(length) +
                                " elements, the IDL bound is " + std::to_string(bound));
  }
}

}  // namespace

void check_bounds(const thermovis::DetectionArray& sample) {
  check(sample.detections().size(), thermovis::MAX_TARGETS, "DetectionArray.detections");
}

void check_bounds(const thermovis::MatchArray& sample) {
  check(sample.targets().size(), thermovis::MAX_TARGETS, "MatchArray.targets");
  for (const auto& target : sample.targets()) {
    check(target.points().size(), thermovis::MAX_POINT_MATCHES, "MatchArray.targets[].points");
  }
}

void check_bounds(const thermovis::RangeArray& sample) {
  check(sample.targets().size(), thermovis::MAX_TARGETS, "RangeArray.targets");
}

void check_bounds(const thermovis::Health& sample) {
  check(sample.topics().size(), thermovis::MAX_HEALTH_TOPICS, "Health.topics");
}

void check_bounds(const thermovis::ObstacleArray& sample) {
  check(sample.obstacles().size(), thermovis::MAX_OBSTACLES, "ObstacleArray.obstacles");
  check(sample.free_space_m().size(), thermovis::MAX_FREE_SPACE_COLUMNS,
        "ObstacleArray.free_space_m");
  check(sample.free_space_row().size(), thermovis::MAX_FREE_SPACE_COLUMNS,
        "ObstacleArray.free_space_row");
}

}  // namespace thermovis::transport
