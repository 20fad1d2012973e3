#include "thermovis/fpga/table_export.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace thermovis::fpga {

namespace {

void write_entries(const cv::Mat& entries, cv::Size full_size, cv::Size source_size, bool quarter,
                   const std::filesystem::path& path, TableFormat format) {
  const std::filesystem::path tmp = path.string() + ".part";
  {
    std::ofstream out(tmp, format == TableFormat::bin ? std::ios::binary : std::ios::out);
    if (!out) throw std::runtime_error("table export: cannot write " + path.string());
    if (format == TableFormat::hex) {
      out << "// thermovis remap table: " << entries.cols << "x" << entries.rows << " entries"
          << (quarter ? " (top-left quarter of " : " (full table ") << full_size.width << "x"
          << full_size.height << "), source " << source_size.width << "x" << source_size.height
          << ", Q11.5 offsets from the source centre, word = qx << 16 | qy\n";
    }
    char line[16];
    for (int v = 0; v < entries.rows; ++v) {
      const auto* row = entries.ptr<cv::Vec2s>(v);
      for (int u = 0; u < entries.cols; ++u) {
        const std::uint32_t word = table_word({row[u][0], row[u][1]});
        if (format == TableFormat::hex) {
          std::snprintf(line, sizeof line, "%08x\n", word);
          out << line;
        } else {
          const unsigned char bytes[4] = {
              static_cast<unsigned char>(word & 0xff), static_cast<unsigned char>(word >> 8),
              static_cast<unsigned char>(word >> 16), static_cast<unsigned char>(word >> 24)};
          out.write(reinterpret_cast<const char*>(bytes), 4);
        }
      }
    }
    if (!out) throw std::runtime_error("table export: write failed for " + path.string());
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace

void export_table(const FixedPointMap& map, const std::filesystem::path& path, TableFormat format) {
  write_entries(map.entries(), map.size(), map.source_size(), false, path, format);
}

void export_table(const QuarterTable& table, const std::filesystem::path& path,
                  TableFormat format) {
  write_entries(table.quarter(), table.full_size(), table.source_size(), true, path, format);
}

cv::Mat read_table(const std::filesystem::path& path, TableFormat format, cv::Size table_size) {
  std::ifstream in(path, format == TableFormat::bin ? std::ios::binary : std::ios::in);
  if (!in) throw std::runtime_error("table read: cannot open " + path.string());
  cv::Mat entries(table_size, CV_16SC2);
  std::string line;
  for (int v = 0; v < table_size.height; ++v) {
    auto* row = entries.ptr<cv::Vec2s>(v);
    for (int u = 0; u < table_size.width; ++u) {
      std::uint32_t word = 0;
      if (format == TableFormat::hex) {
        do {
          if (!std::getline(in, line)) {
            throw std::runtime_error("table read: " + path.string() + " ends early");
          }
        } while (line.rfind("//", 0) == 0);
        word = static_cast<std::uint32_t>(std::stoul(line, nullptr, 16));
      } else {
        unsigned char bytes[4];
        if (!in.read(reinterpret_cast<char*>(bytes), 4)) {
          throw std::runtime_error("table read: " + path.string() + " ends early");
        }
        word = bytes[0] | (bytes[1] << 8) | (bytes[2] << 16) | (std::uint32_t(bytes[3]) << 24);
      }
      row[u] = cv::Vec2s(static_cast<short>(static_cast<std::uint16_t>(word >> 16)),
                         static_cast<short>(static_cast<std::uint16_t>(word & 0xffff)));
    }
  }
  return entries;
}

}  // namespace thermovis::fpga
