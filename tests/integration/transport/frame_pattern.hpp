#pragma once
// A frame content both test processes can compute from the sequence number alone, so the
// receiver checks every byte it got without the sender sending a checksum.
#include <cstddef>
#include <cstdint>

namespace thermovis::test {

// Byte i of image `eye` (0 left, 1 right) of frame `seq`: a 32-bit mix of the three, so a
// shifted, stale or swapped buffer fails.
inline std::uint8_t pattern_byte(std::uint64_t seq, int eye, std::size_t i) {
  std::uint32_t x = static_cast<std::uint32_t>(i) * 2654435761u ^
                    static_cast<std::uint32_t>(seq * 40503u + static_cast<std::uint64_t>(eye));
  x ^= x >> 15;
  return static_cast<std::uint8_t>(x);
}

inline void fill_pattern(std::uint8_t* data, std::size_t size, std::uint64_t seq, int eye) {
  for (std::size_t i = 0; i < size; ++i) data[i] = pattern_byte(seq, eye, i);
}

// Number of bytes that differ from the pattern.
inline std::size_t pattern_errors(const std::uint8_t* data, std::size_t size, std::uint64_t seq,
                                  int eye) {
  std::size_t errors = 0;
  for (std::size_t i = 0; i < size; ++i) errors += data[i] != pattern_byte(seq, eye, i) ? 1 : 0;
  return errors;
}

}  // namespace thermovis::test
