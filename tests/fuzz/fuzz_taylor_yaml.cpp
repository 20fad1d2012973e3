// libFuzzer target: one camera's calibration YAML as `thermovis calibrate` writes it
// (runtime::parse_taylor_yaml). Documented error: ConfigError.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/yaml_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace tf = thermovis::fuzz;
  const std::string text(reinterpret_cast<const char*>(data), size);
  tf::parses<thermovis::runtime::ConfigError>([&] {
    const auto intrinsics = thermovis::runtime::parse_taylor_yaml(text, tf::kSource);
    if (intrinsics.width <= 0 || intrinsics.height <= 0)
      tf::fail("accepted camera", "image size not positive");
    for (double a : intrinsics.pol)
      if (!std::isfinite(a)) tf::fail("accepted camera", "non-finite coefficient");
  });
  return 0;
}
