#include "camera_layers.hpp"

#include <algorithm>
#include <cmath>

namespace thermovis::sim::detail {

CameraLayers camera_geometry(Slot slot, const camera::RigCamera& cam) {
  CameraLayers c;
  c.camera = &cam;
  c.visible = slot == Slot::visible_left || slot == Slot::visible_right;
  c.size = cam.model->image_size();
  c.channels = c.visible ? 3 : 1;
  c.centre = cam.T_ref_cam.translation();
  c.R_world_cam = cam.T_ref_cam.linear();
  c.T_cam_world = cam.T_ref_cam.inverse();
  Eigen::Vector3d a, b;
  const Eigen::Vector2d mid(c.size.width / 2.0, c.size.height / 2.0);
  if (cam.model->unproject(mid, a) && cam.model->unproject(mid + Eigen::Vector2d(1, 0), b))
    c.pixel_angle_rad = std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0));
  return c;
}

}  // namespace thermovis::sim::detail
