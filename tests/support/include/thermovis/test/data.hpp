#pragma once
// Where tests find the shared test data, the source tree and the built executables.
#include <gtest/gtest.h>
#include <filesystem>
#include <string>

namespace thermovis::test {

// The test-data root: $THERMOVIS_TEST_DATA if set, else ../shared/data beside the source tree.
std::filesystem::path data_root();

// data_root()/relative if it exists, else an empty path.
std::filesystem::path data_path(const std::string& relative);

// The project source root (for shipped configs under deploy/).
std::filesystem::path source_root();

// The folder holding the built executables (build/bin).
std::filesystem::path bin_dir();

// Runs the built `thermovis` executable with `args` (a shell command line's arguments) and
// returns its exit code (-1 when it did not exit normally) and its stdout and stderr together.
struct CommandResult {
  int exit_code = 0;
  std::string output;
};
CommandResult run_thermovis(const std::string& args);

// A fresh, empty temporary folder for one test, removed when the test ends unless it failed (a
// failed test's folders are kept, and named on stdout, for inspection).
std::filesystem::path temp_dir(const std::string& name);

// A DDS domain id no other test process on this machine holds: the first of 20..232 (starting at
// a pid-dependent place) whose lock file in the temp folder this process can lock. The lock is
// held until the process exits, so tests running in parallel never share a domain.
int private_domain();
// Another such domain, distinct from private_domain(): for a test whose two stages' participants
// must not meet (a stage's departing participants are still announced for a while).
int second_private_domain();

}  // namespace thermovis::test

// Skips the current test with a message when a data folder is missing, so the project still
// builds and tests where the shared data is not present.
#define THERMOVIS_REQUIRE_DATA(var, relative)                                       \
  const std::filesystem::path var = ::thermovis::test::data_path(relative);         \
  if (var.empty()) {                                                                \
    GTEST_SKIP() << "test data missing: " << (relative) << " under "                \
                 << ::thermovis::test::data_root() << " (set THERMOVIS_TEST_DATA)"; \
  }
