#pragma once
// The ranges transport_peer publishes for frame `seq`, known to the test that checks what
// another process (thermovis-tap) received.
#include <cstdint>
#include <string>

namespace thermovis::test {

struct ExpectedTarget {
  std::uint32_t target_id;
  std::string label;
  float distance_m, sigma_m, x_m, y_m, z_m;
  float box_x, box_y, box_width, box_height;
  std::uint32_t point_count;
};

constexpr int kTargetsPerFrame = 2;

inline std::int64_t expected_capture_time_ns(std::uint64_t seq) {
  return 1'700'000'000'000'000'000 + static_cast<std::int64_t>(seq) * 20'000'000;
}

inline ExpectedTarget expected_target(std::uint64_t seq, int t) {
  const float distance = 10.0f * static_cast<float>(t + 1) + 0.5f * static_cast<float>(seq);
  return {static_cast<std::uint32_t>(t + 1),
          t == 0 ? "person" : "vehicle",
          distance,
          0.25f,
          -1.5f + 3.0f * static_cast<float>(t),
          0.5f,
          distance,
          100.0f * static_cast<float>(t + 1),
          200.0f,
          40.0f,
          90.0f,
          static_cast<std::uint32_t>(12 + t)};
}

}  // namespace thermovis::test
