// libFuzzer target: the rig YAML reader (runtime::parse_rig). Documented error: ConfigError.
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
    const thermovis::camera::Rig rig = thermovis::runtime::parse_rig(text, tf::kSource);
    // An accepted rig is usable: its reference camera exists and every camera has an image.
    if (!rig.has_camera(rig.reference)) tf::fail("accepted rig", "no reference camera");
    for (const auto& camera : rig.cameras) {
      const auto size = camera.model->image_size();
      if (size.width <= 0 || size.height <= 0) tf::fail("accepted rig", camera.name + ": no image");
    }
  });
  return 0;
}
