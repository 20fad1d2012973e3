#pragma once
// Checks of the IDL sequence bounds before a sample is written. fastddsgen 2.3 generates
// std::vector for bounded sequences and serialises any length, while a reader of another
// vendor (Cyclone DDS) drops a sample that exceeds a bound: so the writer refuses it here with
// a clear error instead. Bounded strings need no check (fixed_string truncates).
#include "thermovis/healthPubSubTypes.h"
#include "thermovis/obstaclesPubSubTypes.h"
#include "thermovis/perceptionPubSubTypes.h"

namespace thermovis::transport {

// Each throws std::invalid_argument naming the field, its length and its bound.
void check_bounds(const thermovis::DetectionArray& sample);
void check_bounds(const thermovis::MatchArray& sample);
void check_bounds(const thermovis::RangeArray& sample);
void check_bounds(const thermovis::Health& sample);
void check_bounds(const thermovis::ObstacleArray& sample);

// True for types with a check_bounds overload.
template <class T>
concept HasBounds = requires(const T& sample) {
  check_bounds(sample);
};

}  // namespace thermovis::transport
