#include "thermovis/node/pipeline_grid.hpp"

#include <map>

namespace thermovis::node {

void add_grid_options(CLI::App& app, GridOptions& options) {
  app.add_option("--grid-scale", options.scale,
                 "rectified grid resolution relative to the visible camera's")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 1.0));
  const std::map<std::string, camera::RectifiedProjection> projections{
      {"equirectangular", camera::RectifiedProjection::equirectangular},
      {"cylindrical", camera::RectifiedProjection::cylindrical}};
  app.add_option("--projection", options.projection, "equirectangular | cylindrical")
      ->transform(CLI::CheckedTransformer(projections, CLI::ignore_case));
  app.add_option("--registration-m", options.registration_distance_m,
                 "distance at which infrared is registered onto visible, m (0: infinity)")
      ->capture_default_str();
}

rectify::StereoGeometry pipeline_geometry(const camera::Rig& rig, const GridOptions& options) {
  const auto grid = camera::scaled(rectify::default_pair_grid(rig, rig.visible, options.projection),
                                   options.scale);
  return rectify::make_stereo_geometry(rig, rig.visible, grid);
}

rectify::StereoGeometry registered_infrared_geometry(const camera::Rig& rig,
                                                     const rectify::StereoGeometry& visible) {
  rectify::StereoGeometry g = visible;
  const Eigen::Vector3d left = rig.camera(rig.infrared.left).T_ref_cam.translation();
  const Eigen::Vector3d right = rig.camera(rig.infrared.right).T_ref_cam.translation();
  g.left = rig.infrared.left;
  g.right = rig.infrared.right;
  g.T_ref_left_rect.translation() = left;
  g.T_ref_right_rect.translation() = right;
  g.baseline_m = (g.T_ref_left_rect.linear().transpose() * (right - left)).x();
  return g;
}

}  // namespace thermovis::node
