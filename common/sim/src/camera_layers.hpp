#pragma once
// Internal: what the simulated rig keeps per camera: its geometry, then the layers its set-up
// computes once (the renderer traces the static scene, the noise model draws the fixed
// pattern) and the static cache stores. World frame and units as in scene.hpp.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "thermovis/camera/rig.hpp"
#include "thermovis/sim/simulated_rig.hpp"

namespace thermovis::sim::detail {

struct CameraLayers {
  const camera::RigCamera* camera = nullptr;
  bool visible = true;
  cv::Size size;
  int channels = 3;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // world frame, m
  Eigen::Matrix3d R_world_cam = Eigen::Matrix3d::Identity();
  Eigen::Isometry3d T_cam_world = Eigen::Isometry3d::Identity();
  double pixel_angle_rad = 1e-3;  // at the image centre, for texture level of detail
  cv::Mat rays;                   // CV_32FC3, unit rays in the world frame (NaN: no ray)
  cv::Mat static_depth;           // CV_32FC1, m along the ray (inf: sky)
  cv::Mat static_id;              // CV_16UC1
  cv::Mat static_linear;         // CV_32FC3 (visible DN, before blur) or CV_32FC1 (infrared signal)
  cv::Mat static_clean;          // CV_8UC3 or CV_16UC1: the noise-free image of the static scene
  cv::Mat static_sigma;          // CV_8UC3: visible noise sigma x16 of static_clean
  cv::Mat fpn_offset, fpn_gain;  // CV_32FC1, infrared

  // The raw image's type: CV_8UC3 (visible) or CV_16UC1 (infrared counts).
  int image_type() const { return visible ? CV_8UC3 : CV_16UC1; }
  // The largest raw count of the camera's bit depth.
  int max_count() const { return (1 << camera->bit_depth) - 1; }
};

// The geometry of the camera in `slot` (size, band, pose, pixel angle); no layers yet.
CameraLayers camera_geometry(Slot slot, const camera::RigCamera& cam);

}  // namespace thermovis::sim::detail
