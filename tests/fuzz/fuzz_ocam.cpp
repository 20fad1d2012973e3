// libFuzzer target: OCamCalib's calib_results.txt reader (camera::parse_ocam_calib_results).
// Documented error: std::runtime_error naming the file and the block.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

#include "fuzz_support.hpp"
#include "thermovis/camera/ocam_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace tf = thermovis::fuzz;
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  tf::parses<std::runtime_error>([&] {
    const auto intrinsics = thermovis::camera::parse_ocam_calib_results(in, tf::kSource);
    if (intrinsics.width <= 0 || intrinsics.height <= 0)
      tf::fail("accepted calibration", "image size not positive");
    // What was read is written back and read again to the same model.
    std::stringstream text;
    thermovis::camera::write_ocam_calib_results(intrinsics, text);
    const auto again = thermovis::camera::parse_ocam_calib_results(text, tf::kSource);
    if (again.width != intrinsics.width || again.height != intrinsics.height ||
        again.pol.size() != intrinsics.pol.size())
      tf::fail("round trip", "the written file reads back differently");
  });
  return 0;
}
