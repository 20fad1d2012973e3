// libFuzzer target: the simulated scene YAML reader (runtime::parse_scene). Documented error:
// ConfigError.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace tf = thermovis::fuzz;
  const std::string text(reinterpret_cast<const char*>(data), size);
  tf::parses<thermovis::runtime::ConfigError>(
      [&] { (void)thermovis::runtime::parse_scene(text, tf::kSource); });
  return 0;
}
