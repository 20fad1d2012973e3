#pragma once
// Scene YAML for the simulated rig (sim/scene.hpp); the format is documented in
// deploy/scenes/README.md. Strict: unknown keys, negative or zero sizes, targets behind the
// camera and unknown textures are ConfigErrors naming the file and line.
#include <filesystem>
#include <string>

#include "thermovis/sim/scene.hpp"

namespace thermovis::runtime {

sim::Scene parse_scene(const std::string& yaml_text, const std::string& source_name);
sim::Scene load_scene(const std::filesystem::path& path);

// A scene shipped with the project (deploy/scenes/<name>.yaml), located from $THERMOVIS_SCENES,
// then the source tree, then the installed share folder.
std::filesystem::path shipped_scene_path(const std::string& name);
// A --scene argument: a path as given when it exists or looks like one (a '/' or an
// extension), else the name of a shipped scene (shipped_scene_path, same error).
std::filesystem::path scene_argument_path(const std::string& arg);

}  // namespace thermovis::runtime
