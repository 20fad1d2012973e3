#pragma once
// A rig of cameras with known poses: the paper's four (visible left/right, infrared left/right).
// Poses are given in the reference camera's frame (the left visible camera by convention):
// p_ref = T_ref_cam * p_cam, metres; camera frames as in camera_model.hpp.
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "thermovis/camera/camera_model.hpp"

namespace thermovis::camera {

struct RigCamera {
  std::string name;  // e.g. "visible.left"
  std::string band;  // "visible" or "infrared"
  std::shared_ptr<const CameraModel> model;
  double pixel_pitch_um = 0.0;  // sensor pixel pitch, um
  int bit_depth = 8;            // significant bits per sample of the raw image
  Eigen::Isometry3d T_ref_cam = Eigen::Isometry3d::Identity();
};

// A stereo pair of the rig, by camera names.
struct StereoPair {
  std::string left;
  std::string right;
};

struct Rig {
  std::string name;
  std::string reference;  // camera whose frame is the rig frame
  std::vector<RigCamera> cameras;
  StereoPair visible{"visible.left", "visible.right"};
  StereoPair infrared{"infrared.left", "infrared.right"};
  std::vector<std::string> notes;  // assumptions the rig file states (where values came from)

  // Throws std::out_of_range naming the missing camera.
  const RigCamera& camera(const std::string& camera_name) const;
  bool has_camera(const std::string& camera_name) const;
  // Pose of camera b in camera a's frame: p_a = T * p_b.
  Eigen::Isometry3d relative_pose(const std::string& a, const std::string& b) const;
  // Distance between the two cameras' centres, m.
  double baseline_m(const std::string& a, const std::string& b) const;
};

}  // namespace thermovis::camera
