#include "thermovis/test/data.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace thermovis::test {

std::filesystem::path data_root() {
  if (const char* env = std::getenv("THERMOVIS_TEST_DATA"); env != nullptr && *env != '\0') {
    return env;
  }
  return THERMOVIS_DEFAULT_TEST_DATA;
}

std::filesystem::path data_path(const std::string& relative) {
  const std::filesystem::path path = data_root() / relative;
  return std::filesystem::exists(path) ? path : std::filesystem::path{};
}

std::filesystem::path source_root() {
  if (const char* env = std::getenv("THERMOVIS_SOURCE_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return THERMOVIS_SOURCE_DIR;
}

std::filesystem::path bin_dir() {
  if (const char* env = std::getenv("THERMOVIS_BIN_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return THERMOVIS_BIN_DIR;
}

namespace {

// Removes the folders temp_dir() made for a test when it ends: a passed or skipped test's go, a
// failed test's stay for inspection (their paths are printed).
class TempDirCleaner final : public ::testing::EmptyTestEventListener {
 public:
  void add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mutex_);
    dirs_.push_back(dir);
  }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    std::vector<std::filesystem::path> dirs;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      dirs.swap(dirs_);
    }
    for (const auto& dir : dirs) {
      if (info.result()->Failed()) {
        std::cout << "test folder kept for inspection: " << dir.string() << std::endl;
        continue;
      }
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  }

 private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

TempDirCleaner& temp_dir_cleaner() {
  // Registered on first use, inside a running test; GoogleTest owns (and deletes) it.
  static TempDirCleaner* cleaner = [] {
    auto* c = new TempDirCleaner;
    ::testing::UnitTest::GetInstance()->listeners().Append(c);
    return c;
  }();
  return *cleaner;
}

}  // namespace

std::filesystem::path temp_dir(const std::string& name) {
  std::random_device rd;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("thermovis-" + name + "-" + std::to_string(rd()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  temp_dir_cleaner().add(dir);
  return dir;
}

namespace {

// The first domain of 20..232 from `start` on whose lock file this process gets the lock (held
// until the process exits: the file stays open), other than `not_this`.
int lock_free_domain(int start, int not_this) {
  constexpr int kFirst = 20, kCount = 213;  // domains 20..232
  for (int i = 0; i < kCount; ++i) {
    const int d = kFirst + (start + i) % kCount;
    if (d == not_this) continue;
    const std::string lock = (std::filesystem::temp_directory_path() /
                              ("thermovis-test-domain-" + std::to_string(d) + ".lock"))
                                 .string();
    const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return d;  // fd stays open: the lock is held
    ::close(fd);
  }
  throw std::runtime_error("no free DDS domain for this test: all 213 are held");
}

}  // namespace

int private_domain() {
  static const int domain = lock_free_domain(static_cast<int>(::getpid() % 213), -1);
  return domain;
}

int second_private_domain() {
  static const int domain =
      lock_free_domain(static_cast<int>(::getpid() % 213) + 1, private_domain());
  return domain;
}

CommandResult run_thermovis(const std::string& args) {
  const std::string cmd = (bin_dir() / "thermovis").string() + " " + args + " 2>&1";
  CommandResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed: " + cmd};
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), pipe) != nullptr) r.output += buf.data();
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

}  // namespace thermovis::test
