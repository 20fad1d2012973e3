#pragma once
// A frame content both test processes can compute from the sequence number alone, so the
// receiver checks every byte it got without the sender sending a checksum. Computed in 64-bit
// words so that checking a 12 MB frame stays cheap on a loaded machine.
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace thermovis::test {

// Word i of image `eye` (0 left, 1 right) of frame `seq`: a 64-bit mix of the three, so a
// shifted, stale or swapped buffer fails.
inline std::uint64_t pattern_word(std::uint64_t seq, int eye, std::size_t i) {
  std::uint64_t x = (seq << 40) ^ (static_cast<std::uint64_t>(eye) << 32) ^ i;
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  return x;
}

// `size` must be a multiple of 8 (every frame array is).
inline void fill_pattern(std::uint8_t* data, std::size_t size, std::uint64_t seq, int eye) {
  for (std::size_t i = 0; i < size / 8; ++i) {
    const std::uint64_t word = pattern_word(seq, eye, i);
    std::memcpy(data + 8 * i, &word, 8);
  }
}

// Number of 8-byte words that differ from the pattern.
inline std::size_t pattern_errors(const std::uint8_t* data, std::size_t size, std::uint64_t seq,
                                  int eye) {
  std::size_t errors = 0;
  for (std::size_t i = 0; i < size / 8; ++i) {
    std::uint64_t word;
    std::memcpy(&word, data + 8 * i, 8);
    errors += word != pattern_word(seq, eye, i) ? 1 : 0;
  }
  return errors;
}

}  // namespace thermovis::test
