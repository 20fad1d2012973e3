#pragma once
// A command's --scene argument: a path, or the name of a shipped scene
// (deploy/scenes/<name>.yaml).
#include <filesystem>
#include <string>

#include "thermovis/runtime/scene_io.hpp"

namespace thermovis::cli {

inline std::filesystem::path resolve_scene(const std::string& arg) {
  return runtime::scene_argument_path(arg);
}

}  // namespace thermovis::cli
