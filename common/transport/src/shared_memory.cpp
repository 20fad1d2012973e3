#include "thermovis/transport/shared_memory.hpp"

#include <fstream>
#include <sstream>

namespace thermovis::transport {

std::optional<Mapping> mapping_of(const void* address) {
  const auto target = reinterpret_cast<std::uintptr_t>(address);
  std::ifstream maps("/proc/self/maps");
  std::string line;
  // Line format: "begin-end perms offset dev inode   path" (hex numbers).
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
    if (target < mapping.begin || target >= mapping.end) continue;
    mapping.offset = std::stoull(offset, nullptr, 16);
    mapping.path = path;
    return mapping;
  }
  return std::nullopt;
}

std::uint64_t file_offset(const Mapping& mapping, const void* address) {
  return mapping.offset + (reinterpret_cast<std::uintptr_t>(address) - mapping.begin);
}

bool is_data_sharing_segment(const std::string& path) {
  return path.rfind("/dev/shm/fast_datasharing", 0) == 0;
}

}  // namespace thermovis::transport
