#pragma once
// Correspondences as the matcher sends them, for the tests that feed thermovis-range directly:
// a marker 12 m ahead (0.3 m right, 0.2 m down of the left visible camera) on the pipeline's
// visible grid, a 5 x 5 grid of points 3 cm apart in a 20 x 20 px box.
#include <Eigen/Core>
#include <cstdint>

#include "pipeline_harness.hpp"
#include "thermovis/perception.h"
#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/range/ranging.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace thermovis::test {

// The pipeline's geometry on the default rig and grid options (what thermovis-rectify-fuse
// publishes, and what the tests' harnesses publish for the services they start alone).
inline pipeline::PipelineGeometry pipeline_geometry() {
  return pipeline::make_geometry(runtime::load_rig(runtime::default_rig_path()), {});
}

inline TargetMatch marker_matches(std::uint32_t id, Band band) {
  const auto visible = pipeline_geometry().ranging(pipeline::Band::visible);
  TargetMatch target;
  target.target_id(id);
  target.label("marker");
  target.band(band);
  Eigen::Vector2d centre;
  double disparity = 0;
  range::project_point(visible.grid, visible.baseline_m, {0.3, 0.2, 12.0}, centre, disparity);
  target.box(
      box2d(static_cast<float>(centre.x() - 10), static_cast<float>(centre.y() - 10), 20.f, 20.f));
  for (int dy = -6; dy <= 6; dy += 3) {
    for (int dx = -6; dx <= 6; dx += 3) {
      Eigen::Vector2d px;
      double d = 0;
      range::project_point(visible.grid, visible.baseline_m,
                           {0.3 + dx * 0.01, 0.2 + dy * 0.01, 12.0}, px, d);
      PointMatch m;
      m.left_x(static_cast<float>(px.x()));
      m.left_y(static_cast<float>(px.y()));
      m.right_x(static_cast<float>(px.x() - d));
      m.right_y(static_cast<float>(px.y()));
      target.points().push_back(m);
    }
  }
  return target;
}

}  // namespace thermovis::test
