#include "thermovis/test/data.hpp"

#include <cstdlib>
#include <random>

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

std::filesystem::path temp_dir(const std::string& name) {
  std::random_device rd;
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("thermovis-" + name + "-" + std::to_string(rd()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace thermovis::test
