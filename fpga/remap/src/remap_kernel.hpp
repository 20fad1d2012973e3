#pragma once
// The vector kernel of FastRemapper (remap.hpp): bilinear samples of a run of output pixels
// whose four neighbours all lie inside the source (the table's "interior" runs). Written with
// Google Highway and dispatched at run time to the best instruction set of the CPU
// (remap_kernel.cpp). Private to the fpga library.
#include <cstddef>
#include <cstdint>

namespace thermovis::fpga::detail {

// One table entry as the fast path stores it, 4 bytes: the absolute source position in 1/32 px
// (fixed_map.hpp's x_q5, y_q5) plus one pixel, y in the high 16 bits, x in the low 16 bits, both
// unsigned. The pixel added makes every entry that samples anything (top-left neighbour at
// column or row -1 or more) non-negative; sources are at most 2046 px wide and high, so
// (2046 + 1) * 32 fits. Integer part ((q >> 5) - 1) and fraction (q & 31) come back unchanged:
// adding 32 leaves the low 5 bits as they were.
inline constexpr int kEntryBias = 32;  // one pixel in 1/32 px
inline std::uint32_t pack_entry(int x_q5, int y_q5) {
  return (static_cast<std::uint32_t>(y_q5 + kEntryBias) << 16) |
         static_cast<std::uint32_t>(x_q5 + kEntryBias);
}
inline int entry_x_q5(std::uint32_t entry) { return static_cast<int>(entry & 0xffff) - kEntryBias; }
inline int entry_y_q5(std::uint32_t entry) { return static_cast<int>(entry >> 16) - kEntryBias; }

// One run of `count` consecutive output pixels of one row.
struct InteriorRun {
  const std::uint8_t* source;  // the source's first row
  std::int32_t step;           // source row pitch, bytes (the kernel's offsets are int32)
  // One past the source's last byte: its last row's end (a view's parent may go on, but
  // nothing beyond this is read).
  const std::uint8_t* source_end;
  const std::uint32_t* entries;  // pack_entry(x_q5, y_q5) per output pixel
  void* out;                     // the run's first output pixel
  int count;
};

// Every read must lie inside the source rows, including the 8-bit grey path's 4-byte and the
// BGR path's 8-byte loads (2 bytes beyond the right neighbour): the table marks a pixel
// interior only then (on the source's last row, x0 + 3 < width). The grey kernels' windows
// (16 bytes of three or four rows per block of 8 or 4 pixels) are read only where they end
// before source_end.
void remap_interior_8uc1(const InteriorRun& run);
void remap_interior_8uc3(const InteriorRun& run);
void remap_interior_16uc1(const InteriorRun& run);

}  // namespace thermovis::fpga::detail
