#include "thermovis/transport/shared_memory.hpp"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace thermovis::transport {

namespace {

// Every mapping of this process, from /proc/self/maps. Line format:
// "begin-end perms offset dev inode   path" (hex numbers; path empty for anonymous memory).
std::vector<Mapping> mappings(const std::string& maps_file = "/proc/self/maps") {
  std::vector<Mapping> out;
  std::ifstream maps(maps_file);
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

StaleSegments remove_stale_data_sharing_segments(std::chrono::seconds min_age,
                                                 const std::filesystem::path& shm_dir) {
  namespace fs = std::filesystem;
  // Every data-sharing segment some live process maps (its own pool or one it reads).
  std::set<std::string> in_use;
  std::error_code ec;
  for (const auto& proc : fs::directory_iterator("/proc", ec)) {
    const std::string pid = proc.path().filename().string();
    if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) continue;
    for (const auto& mapping : mappings((proc.path() / "maps").string())) {
      if (mapping.path.find("fast_datasharing") != std::string::npos) {
        in_use.insert(fs::path(mapping.path).filename().string());
      }
    }
  }
  StaleSegments removed;
  const auto now = fs::file_time_type::clock::now();
  for (const auto& entry : fs::directory_iterator(shm_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("fast_datasharing", 0) != 0 || in_use.count(name) > 0) continue;
    std::error_code stat_error;
    const auto modified = fs::last_write_time(entry.path(), stat_error);
    // A segment just created may not be mapped yet: only old ones are stale.
    if (stat_error || now - modified < min_age) continue;
    const auto bytes = fs::file_size(entry.path(), stat_error);
    if (fs::remove(entry.path(), stat_error)) {
      ++removed.count;
      removed.bytes += stat_error ? 0 : bytes;
    }
  }
  return removed;
}

}  // namespace thermovis::transport
