#pragma once
// Internal: the file format of sim::StaticCache (simulated_rig.hpp): the layers each camera's
// set-up computes (camera_layers.hpp) and the noise plane, written once and then mapped, not
// read, so that the pages of the file are the images and only the pixels used are ever read.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "camera_layers.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::sim::detail {

// What the set-up computes for one camera, in the cache file's order: rays, depth, surface id,
// linear values, the noise-free image, then (visible) its noise sigma or (infrared) the
// fixed-pattern offset and gain.
std::vector<cv::Mat*> cached_layers(CameraLayers& c);

// Writes the cameras' layers and the noise plane to `file` (through a temporary file renamed
// over it, so a reader never sees half a file); "" or why not.
std::string write_static_cache(const std::filesystem::path& file, const std::string& key,
                               std::array<CameraLayers, kSlotCount>& cams,
                               const std::vector<std::int8_t>& noise_plane);

// Maps `file` when it holds `key` and the layers of `cams` (whose geometry is set), points
// their layers into it and copies the noise plane (of `plane_size`); "" or why not (a missing,
// foreign, truncated or garbled file). `mapping` keeps the mapping for as long as the layers
// are used; on failure some layers may already point into it: release them before `mapping`.
std::string read_static_cache(const std::filesystem::path& file, const std::string& key,
                              std::array<CameraLayers, kSlotCount>& cams, std::size_t plane_size,
                              std::vector<std::int8_t>& noise_plane,
                              std::shared_ptr<void>& mapping);

}  // namespace thermovis::sim::detail
