#include "thermovis/transport/shared_memory.hpp"

#include <fstream>
#include <set>
#include <sstream>

namespace thermovis::transport {

namespace {

// Every mapping of this process, from /proc/self/maps. Line format:
// "begin-end perms offset dev inode   path" (hex numbers; path empty for anonymous memory).
std::vector<Mapping> mappings() {
  std::vector<Mapping> out;
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line)) {
    std::istringstream fields(line);
    std::string range, perms, offset, device, inode, path;
    fields >> range >> perms >> offset >> device >> inode;
    std::getline(fields >> std::ws, path);
    const auto dash = range.find('-');
    if (dash == std::string::npos) continue;
    Mapping mapping;
    mapping.begin = std::stoull(range.substr(0, dash), nullptr, 16);
    mapping.end = std::stoull(range.substr(dash + 1), nullptr, 16);
    mapping.offset = std::stoull(offset, nullptr, 16);
    mapping.path = path;
    out.push_back(std::move(mapping));
  }
  return out;
}

}  // namespace

std::optional<Mapping> mapping_of(const void* address) {
  const auto target = reinterpret_cast<std::uintptr_t>(address);
  for (auto& mapping : mappings()) {
    if (target >= mapping.begin && target < mapping.end) return mapping;
  }
  return std::nullopt;
}

std::vector<std::string> mapped_data_sharing_segments() {
  std::set<std::string> paths;
  for (const auto& mapping : mappings()) {
    if (is_data_sharing_segment(mapping.path)) paths.insert(mapping.path);
  }
  return {paths.begin(), paths.end()};
}

std::uint64_t file_offset(const Mapping& mapping, const void* address) {
  return mapping.offset + (reinterpret_cast<std::uintptr_t>(address) - mapping.begin);
}

bool is_data_sharing_segment(const std::string& path) {
  return path.rfind("/dev/shm/fast_datasharing", 0) == 0;
}

}  // namespace thermovis::transport
