#pragma once
// What the simulator tests compare: one frame rendered into fresh buffers.
#include <cstdint>

#include "thermovis/sim/simulated_rig.hpp"

// In the simulator's namespace, so that tests find it by argument-dependent lookup.
namespace thermovis::sim {

// Frame `frame_index` of `rig`, in buffers of its own (SimulatedRig::allocate).
inline FrameSet rendered(const SimulatedRig& rig, std::int64_t frame_index) {
  FrameSet frames = rig.allocate();
  rig.render(frame_index, frames);
  return frames;
}

}  // namespace thermovis::sim
