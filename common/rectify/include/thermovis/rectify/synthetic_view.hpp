#pragma once
// Synthetic raw images for checking and demonstrating rectification: what a rig camera sees of
// a pattern painted on the sphere at infinity, rendered through the camera's own model (e.g.
// the Taylor lens), so the rectified result can be compared with where the pattern must land.
#include <Eigen/Geometry>
#include <functional>
#include <opencv2/core/mat.hpp>

#include "thermovis/camera/rig.hpp"

namespace thermovis::rectify {

// Intensity in [0, 1] of the pattern along a unit ray given in the pattern's frame.
using DirectionalPattern = std::function<double(const Eigen::Vector3d& ray)>;

// Renders `camera`'s raw image (its model's size) of `pattern`, whose frame is T_ref_pattern in
// the rig frame (only its rotation matters: the pattern is at infinity). Each pixel averages
// samples x samples points of its area. type: CV_8UC1 (0..255), CV_8UC3 (grey in each channel),
// or CV_16UC1 (0 .. 2^camera.bit_depth - 1). Pixels without a ray are 0.
cv::Mat render_pattern(const camera::RigCamera& camera, const Eigen::Isometry3d& T_ref_pattern,
                       const DirectionalPattern& pattern, int type, int samples = 3);

// A checkerboard in the angles of the rectified grid (camera/rectified.hpp): alpha = asin(x),
// beta = atan2(y, z), squares of square_rad in both; levels 0.15 and 0.85. On an
// equirectangular grid of f px per rad its squares are f * square_rad px, aligned with rows.
DirectionalPattern angular_checkerboard(double square_rad);

// A Gaussian spot of angular standard deviation sigma_rad around the unit direction `centre`.
DirectionalPattern angular_spot(const Eigen::Vector3d& centre, double sigma_rad);

}  // namespace thermovis::rectify
