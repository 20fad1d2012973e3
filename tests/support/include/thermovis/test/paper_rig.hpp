#pragma once
// The paper's rig (deploy/rigs/paper.yaml), loaded once per test executable, and its cameras'
// Taylor models. Header-only: for tests that link thermovis::runtime (test_support itself needs
// neither the camera models nor YAML).
#include <string>

#include "thermovis/camera/rig.hpp"
#include "thermovis/camera/taylor.hpp"
#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/test/data.hpp"

namespace thermovis::test {

inline const camera::Rig& paper_rig() {
  static const camera::Rig rig = runtime::load_rig(source_root() / "deploy/rigs/paper.yaml");
  return rig;
}

// The Taylor model of the paper rig's camera `name` ("visible.left", ...).
inline const camera::TaylorCamera& paper_taylor_camera(const std::string& name) {
  return dynamic_cast<const camera::TaylorCamera&>(*paper_rig().camera(name).model);
}

}  // namespace thermovis::test
