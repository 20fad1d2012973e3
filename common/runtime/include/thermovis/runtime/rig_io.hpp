#pragma once
// Rig and camera YAML (see deploy/rigs/paper.yaml for the documented format).
//
// A camera entry:
//   band: visible | infrared
//   pixel_pitch_um: 13
//   bit_depth: 8
//   model:
//     type: taylor
//     image_size: [width, height]
//     centre_row_col: [xc, yc]        # OCamCalib order: ROW then COLUMN, 0-based px
//     affine_cde: [c, d, e]
//     pol: [a0, a1, a2, a3, a4]       # px
//     invpol: [...]                   # optional, lowest order first; fitted when absent
// Extrinsics: X_to = R * X_from + t, camera frames x right, y down, z forward; t in mm.
#include <filesystem>
#include <string>

#include "thermovis/camera/rig.hpp"
#include "thermovis/camera/taylor.hpp"

namespace thermovis::runtime {

// Throws ConfigError naming the file, line and key.
camera::Rig parse_rig(const std::string& yaml_text, const std::string& source_name);
camera::Rig load_rig(const std::filesystem::path& path);
std::string rig_to_yaml(const camera::Rig& rig);
void save_rig(const camera::Rig& rig, const std::filesystem::path& path);

// One camera's intrinsics (the `model:` block alone, as `thermovis calibrate` writes it).
camera::TaylorIntrinsics parse_taylor_yaml(const std::string& yaml_text,
                                           const std::string& source_name);
camera::TaylorIntrinsics load_taylor_yaml(const std::filesystem::path& path);
std::string taylor_to_yaml(const camera::TaylorIntrinsics& intrinsics);

// A file shipped under deploy/ (e.g. "rigs/paper.yaml"), looked up in $THERMOVIS_DEPLOY_DIR, then
// the source tree's deploy/, then /usr/local/share/thermovis/. Throws ConfigError when absent.
std::filesystem::path shipped_file(const std::string& relative);

// The default rig: $THERMOVIS_RIG, else shipped_file("rigs/paper.yaml").
std::filesystem::path default_rig_path();

// The rig a user named with --rig, or the default rig when none was named (empty path).
camera::Rig load_rig_or_default(const std::filesystem::path& path);

}  // namespace thermovis::runtime
