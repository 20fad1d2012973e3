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

namespace {

// The file names under /dev/shm starting with `prefix` that some live process maps.
std::set<std::string> mapped_by_live_processes(const std::string& prefix) {
  namespace fs = std::filesystem;
  std::set<std::string> in_use;
  std::error_code ec;
  for (const auto& proc : fs::directory_iterator("/proc", ec)) {
    const std::string pid = proc.path().filename().string();
    if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) continue;
    for (const auto& mapping : mappings((proc.path() / "maps").string())) {
      const std::string name = fs::path(mapping.path).filename().string();
      if (name.rfind(prefix, 0) == 0) in_use.insert(name);
    }
  }
  return in_use;
}

}  // namespace

int fresh_participant_id(const std::function<std::uint32_t(int)>& metatraffic_port, int max_ids,
                         const std::set<int>& skip, std::chrono::seconds min_age,
                         const std::filesystem::path& shm_dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(shm_dir, ec)) return -1;
  const std::set<std::string> in_use = mapped_by_live_processes("fastrtps_port");
  const auto now = fs::file_time_type::clock::now();
  // False when the port's file is there and in use (or too new to tell); a stale one is removed.
  const auto port_free = [&](std::uint32_t port) {
    const std::string name = "fastrtps_port" + std::to_string(port);
    const fs::path file = shm_dir / name;
    if (!fs::exists(file, ec)) return true;
    if (in_use.count(name) > 0) return false;
    std::error_code stat_error;
    const auto modified = fs::last_write_time(file, stat_error);
    if (stat_error || now - modified < min_age) return false;
    fs::remove(file, stat_error);
    fs::remove(shm_dir / (name + "_el"), stat_error);
    return !fs::exists(file, ec);
  };
  for (int id = 0; id < max_ids; ++id) {
    if (skip.count(id) > 0) continue;
    const std::uint32_t port = metatraffic_port(id);
    // Both unicast ports (metatraffic, user: the next number), each checked (and freed) first.
    const bool metatraffic_free = port_free(port);
    const bool user_free = port_free(port + 1);
    if (metatraffic_free && user_free) return id;
  }
  return -1;
}

StaleSegments remove_stale_data_sharing_segments(std::chrono::seconds min_age,
                                                 const std::filesystem::path& shm_dir) {
  namespace fs = std::filesystem;
  // Every data-sharing segment some live process maps (its own pool or one it reads).
  const std::set<std::string> in_use = mapped_by_live_processes("fast_datasharing");
  std::error_code ec;
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
