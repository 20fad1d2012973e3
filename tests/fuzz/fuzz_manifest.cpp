// libFuzzer target: the supervisor's manifest reader (deploy/pipeline.yaml,
// process::parse_manifest). Documented error: ConfigError.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "thermovis/process/manifest_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace tf = thermovis::fuzz;
  const std::string text(reinterpret_cast<const char*>(data), size);
  tf::parses<thermovis::runtime::ConfigError>([&] {
    const auto manifest = thermovis::process::parse_manifest(text, tf::kSource);
    // An accepted manifest can be started: every service in an order after its dependencies.
    if (thermovis::process::start_order(manifest).size() != manifest.services.size())
      tf::fail("accepted manifest", "start order misses services");
  });
  return 0;
}
