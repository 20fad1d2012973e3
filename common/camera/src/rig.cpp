#include "thermovis/camera/rig.hpp"

#include <stdexcept>

namespace thermovis::camera {

const RigCamera& Rig::camera(const std::string& camera_name) const {
  for (const auto& cam : cameras) {
    if (cam.name == camera_name) return cam;
  }
  std::string known;
  for (const auto& cam : cameras) known += (known.empty() ? "" : ", ") + cam.name;
  throw std::out_of_range("rig '" + name + "' has no camera '" + camera_name +
                          "' (it has: " + known + ")");
}

bool Rig::has_camera(const std::string& camera_name) const {
  for (const auto& cam : cameras) {
    if (cam.name == camera_name) return true;
  }
  return false;
}

Eigen::Isometry3d Rig::relative_pose(const std::string& a, const std::string& b) const {
  return camera(a).T_ref_cam.inverse() * camera(b).T_ref_cam;
}

double Rig::baseline_m(const std::string& a, const std::string& b) const {
  return relative_pose(a, b).translation().norm();
}

}  // namespace thermovis::camera
