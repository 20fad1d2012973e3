#pragma once
// OCamCalib's calib_results.txt (as written by the MATLAB toolbox's export): blocks separated by
// '#' comment lines:
//   polynomial:  N a0 a1 ... a(N-1)
//   inverse:     M p0 p1 ... (lowest order first)
//   centre:      xc yc        (ROW, COLUMN; 0-based, "C convention")
//   affine:      c d e
//   image size:  height width
#include <filesystem>
#include <iosfwd>

#include "thermovis/camera/taylor.hpp"

namespace thermovis::camera {

// Throws std::runtime_error naming the file and the missing or malformed block.
TaylorIntrinsics read_ocam_calib_results(const std::filesystem::path& path);
TaylorIntrinsics parse_ocam_calib_results(std::istream& in, const std::string& source_name);

void write_ocam_calib_results(const TaylorIntrinsics& intrinsics,
                              const std::filesystem::path& path);
void write_ocam_calib_results(const TaylorIntrinsics& intrinsics, std::ostream& out);

}  // namespace thermovis::camera
