#pragma once
// Where a pointer lives: the file mapping of this process (from /proc/self/maps) that contains
// it. Used to check that a sample really sits in a data-sharing segment shared with another
// process (zero-copy) rather than in private heap memory.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace thermovis::transport {

struct Mapping {
  std::uintptr_t begin = 0, end = 0;  // address range [begin, end)
  std::uint64_t offset = 0;           // offset of `begin` in the mapped file, bytes
  std::string path;                   // mapped file ("" for anonymous memory)
};

// The mapping containing `address`, or nothing (e.g. on a system without /proc).
std::optional<Mapping> mapping_of(const void* address);

// Offset of `address` inside the file of its mapping, bytes.
std::uint64_t file_offset(const Mapping& mapping, const void* address);

// True when `path` is a Fast DDS data-sharing segment (/dev/shm/fast_datasharing_*).
bool is_data_sharing_segment(const std::string& path);

// The data-sharing segments this process has mapped (its writers' pools, its readers'
// notification segments and the pools of the writers they read), each once.
std::vector<std::string> mapped_data_sharing_segments();

struct StaleSegments {
  std::size_t count = 0;    // segments removed
  std::uint64_t bytes = 0;  // their size
};

// Removes the data-sharing segments that no live process maps any more (a writer killed with
// SIGKILL leaves its whole pool, ~62 MB for a visible frame topic, in /dev/shm), older than
// `min_age` (a segment just created is mapped a moment later). Scans /proc/*/maps.
StaleSegments remove_stale_data_sharing_segments(
    std::chrono::seconds min_age = std::chrono::seconds(10),
    const std::filesystem::path& shm_dir = "/dev/shm");

// The participant id a new participant on `domain` should take so that its two unicast
// shared-memory ports (/dev/shm/fastrtps_port<metatraffic> and <metatraffic + 1>, from the
// port numbering `port(id)` of the participant's QoS) are new files: the lowest id below
// `max_ids` whose port files do not exist, after removing those that no live process maps and
// that are older than `min_age` (a SIGKILLed process's). -1 when every id's ports are in use
// (then Fast DDS's own choice). Fast DDS numbers each process's participants from 0 and moves a
// busy port on; a service restarted after a SIGKILL so took its dead predecessor's ports, which
// the SHM transport opens only after their health check has timed out (1 s per port): the
// restart then stalled 2 s more.
// Ids in `skip` are not taken (this process's own participants).
int fresh_participant_id(const std::function<std::uint32_t(int)>& metatraffic_port, int max_ids,
                         const std::set<int>& skip = {},
                         std::chrono::seconds min_age = std::chrono::seconds(2),
                         const std::filesystem::path& shm_dir = "/dev/shm");

// Process-shared mutexes this process initialises are robust, and a lock that finds the holder
// dead takes the mutex over (src/robust_mutex.cpp: Fast DDS's data-sharing notifications would
// otherwise stay locked by a killed process).
struct RobustMutexes {
  std::uint64_t made_robust = 0;  // process-shared mutex attributes made robust so far
  std::uint64_t recovered = 0;    // locks that took a mutex over from a dead holder
};
RobustMutexes robust_mutexes();

}  // namespace thermovis::transport
