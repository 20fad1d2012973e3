#pragma once
// The vector kernel of FastRemapper (remap.hpp): bilinear samples of a run of output pixels
// whose four neighbours all lie inside the source (the table's "interior" runs). Written with
// Google Highway and dispatched at run time to the best instruction set of the CPU
// (remap_kernel.cpp). Private to the fpga library.
#include <cstddef>
#include <cstdint>

namespace thermovis::fpga::detail {

// Packs the integer source position (x0, y0) of a table entry (the top-left neighbour, px) in
// one word: y0 in the high 16 bits, x0 in the low 16 bits, both two's complement.
inline std::int32_t pack_position(int x0, int y0) {
  return static_cast<std::int32_t>((static_cast<std::uint32_t>(y0) << 16) |
                                   static_cast<std::uint16_t>(x0));
}
inline int packed_x(std::int32_t packed) { return static_cast<std::int16_t>(packed & 0xffff); }
inline int packed_y(std::int32_t packed) { return packed >> 16; }

// One run of `count` consecutive output pixels of one row.
struct InteriorRun {
  const std::uint8_t* source;      // the source's first row
  std::int32_t step;               // source row pitch, bytes (the kernel's offsets are int32)
  const std::int32_t* positions;   // pack_position(x0, y0) per output pixel
  const std::uint16_t* fractions;  // fy * 32 + fx per output pixel (1/32 px)
  void* out;                       // the run's first output pixel
  int count;
};

// Every read must lie inside the source rows, including the 8-bit grey path's 4-byte and the
// BGR path's 8-byte loads (2 bytes beyond the right neighbour): the table marks a pixel
// interior only then (on the source's last row, x0 + 3 < width).
void remap_interior_8uc1(const InteriorRun& run);
void remap_interior_8uc3(const InteriorRun& run);
void remap_interior_16uc1(const InteriorRun& run);

}  // namespace thermovis::fpga::detail
