#pragma once
// Export of remap tables for the RTL (fixed_map.hpp format; quarter tables hold the top-left
// quadrant only).
//
// hex (Verilog $readmemh): one entry per line, row-major (row 0 first, left to right), as eight
// hex digits: the 16-bit two's complement qx in the high half, qy in the low half, e.g. an
// offset of (-1.5, +2.0) px is qx = -48 = 0xffd0, qy = 64 = 0x0040 -> "ffd00040". A leading
// comment line "// thermovis remap table ..." states the table and source sizes and whether it
// is a quarter table (readmemh ignores // comments).
// bin: the same 32-bit words, little-endian, no header (4 bytes per entry).
#include <filesystem>
#include <iosfwd>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/quarter_table.hpp"

namespace thermovis::fpga {

enum class TableFormat { hex, bin };

// Throws std::runtime_error naming the path when it cannot be written.
void export_table(const FixedPointMap& map, const std::filesystem::path& path, TableFormat format);
void export_table(const QuarterTable& table, const std::filesystem::path& path, TableFormat format);
// The word of one entry as the RTL reads it.
inline std::uint32_t table_word(FixedPointEntry e) {
  return (static_cast<std::uint32_t>(static_cast<std::uint16_t>(e.qx)) << 16) |
         static_cast<std::uint16_t>(e.qy);
}
// Reads a hex or bin table back (for round-trip checks), entries only.
cv::Mat read_table(const std::filesystem::path& path, TableFormat format, cv::Size table_size);

}  // namespace thermovis::fpga
