#include "thermovis/rectify/rig_rectification.hpp"

#include <cmath>

namespace thermovis::rectify {

RectifiedPair rectify_pair(const camera::Rig& rig, const camera::StereoPair& pair,
                           const camera::RectifiedIntrinsics& grid) {
  RectifiedPair out{make_stereo_geometry(rig, pair, grid), {}, {}};
  out.left_map = build_map(rig.camera(pair.left), out.geometry.T_ref_left_rect, out.geometry.grid);
  out.right_map =
      build_map(rig.camera(pair.right), out.geometry.T_ref_right_rect, out.geometry.grid);
  return out;
}

RectifiedPair rectify_pair(const camera::Rig& rig, const camera::StereoPair& pair,
                           camera::RectifiedProjection projection, int width) {
  camera::RectifiedIntrinsics grid = default_pair_grid(rig, pair, projection);
  if (width > 0) {
    grid.width = width;
    grid.cx = (width - 1) / 2.0;
  }
  return rectify_pair(rig, pair, grid);
}

RigRectification rectify_rig(const camera::Rig& rig, const RectificationOptions& options) {
  RigRectification out{rectify_pair(rig, rig.visible, options.projection, options.visible_width),
                       rectify_pair(rig, rig.infrared, options.projection, options.infrared_width),
                       {},
                       {},
                       options.registration_distance_m};
  const StereoGeometry& g = out.visible.geometry;
  out.infrared_left_on_visible = build_map(rig.camera(rig.infrared.left), g.T_ref_left_rect, g.grid,
                                           options.registration_distance_m);
  out.infrared_right_on_visible = build_map(rig.camera(rig.infrared.right), g.T_ref_right_rect,
                                            g.grid, options.registration_distance_m);
  return out;
}

double registration_parallax_px(double f_px_per_rad, double offset_m, double distance_m,
                                double registration_distance_m) {
  const double assumed =
      registration_distance_m > 0.0 ? std::atan(offset_m / registration_distance_m) : 0.0;
  return f_px_per_rad * std::abs(std::atan(offset_m / distance_m) - assumed);
}

}  // namespace thermovis::rectify

namespace thermovis::rectify {

double field_kept_deg(const camera::CameraModel& raw, const cv::Mat& map_xy, int row) {
  if (map_xy.type() != CV_32FC2 || row < 0 || row >= map_xy.rows) return 0.0;
  const auto* entries = map_xy.ptr<cv::Vec2f>(row);
  auto inside = [&](int u) {
    return entries[u][0] >= 0.0f && raw.in_image({entries[u][0], entries[u][1]});
  };
  int first = 0, last = map_xy.cols - 1;
  while (first < map_xy.cols && !inside(first)) ++first;
  while (last > first && !inside(last)) --last;
  if (last <= first) return 0.0;
  Eigen::Vector3d a, b;
  if (!raw.unproject({entries[first][0], entries[first][1]}, a) ||
      !raw.unproject({entries[last][0], entries[last][1]}, b)) {
    return 0.0;
  }
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

}  // namespace thermovis::rectify
