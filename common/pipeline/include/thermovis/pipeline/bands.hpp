#pragma once
// The eyes and bands the pipeline's frames and measurements are named by, apart from the
// geometry (geometry.hpp) so that a frame codec can name them without the camera, rectification
// and ranging headers.

namespace thermovis::pipeline {

enum class Eye { left, right };
// The pair a measurement comes from. fused: the fused images (infrared registered at one
// distance blended into the visible), or a range combined from both pairs.
enum class Band { visible, infrared, fused };

}  // namespace thermovis::pipeline
