// Stale data-sharing segments (pools of killed writers) are removed; segments some process still
// maps, and young ones, are kept.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "thermovis/test/data.hpp"
#include "thermovis/transport/shared_memory.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

void write_segment(const fs::path& path, std::size_t bytes, bool old) {
  std::ofstream(path) << std::string(bytes, 'x');
  if (old) fs::last_write_time(path, fs::file_time_type::clock::now() - 1h);
}

TEST(StaleSegments, OnlyUnmappedOldSegmentsAreRemoved) {
  const fs::path dir = thermovis::test::temp_dir("stale_segments");
  write_segment(dir / "fast_datasharing_dead_0.0.1.3", 4096, true);
  write_segment(dir / "fast_datasharing_mapped_0.0.1.3", 4096, true);
  write_segment(dir / "fast_datasharing_young_0.0.1.3", 4096, false);
  write_segment(dir / "fastrtps_port7411", 4096, true);  // not a data-sharing segment
  // This process maps one of them, as a live writer or reader does.
  const int fd = ::open((dir / "fast_datasharing_mapped_0.0.1.3").c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  void* map = ::mmap(nullptr, 4096, PROT_READ, MAP_SHARED, fd, 0);
  ASSERT_NE(map, MAP_FAILED);

  const auto removed = thermovis::transport::remove_stale_data_sharing_segments(10s, dir);
  EXPECT_EQ(removed.count, 1u);
  EXPECT_EQ(removed.bytes, 4096u);
  EXPECT_FALSE(fs::exists(dir / "fast_datasharing_dead_0.0.1.3"));
  EXPECT_TRUE(fs::exists(dir / "fast_datasharing_mapped_0.0.1.3"));
  EXPECT_TRUE(fs::exists(dir / "fast_datasharing_young_0.0.1.3"));
  EXPECT_TRUE(fs::exists(dir / "fastrtps_port7411"));

  ::munmap(map, 4096);
  ::close(fd);
  // Unmapped now, and old: the next sweep takes it.
  EXPECT_EQ(thermovis::transport::remove_stale_data_sharing_segments(10s, dir).count, 1u);
  EXPECT_FALSE(fs::exists(dir / "fast_datasharing_mapped_0.0.1.3"));
  fs::remove_all(dir);
}

}  // namespace
