#pragma once
// Epipolar rectification ("limit correction") of a wide-angle stereo pair onto the rectified grid
// of camera/rectified.hpp, and the per-camera maps from rectified pixels to raw pixels.
//
// Frames: the rig frame is the reference camera's (camera/rig.hpp). A rectified frame has its x
// axis along the baseline (left camera centre -> right camera centre), z the mean of the two
// optical axes made orthogonal to x, y = z cross x (down). The left and right rectified frames
// share this rotation; their origins are the two camera centres. In them, an epipolar plane is one
// row.
#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <vector>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/camera/rig.hpp"

namespace thermovis::rectify {

struct StereoGeometry {
  std::string left, right;             // camera names in the rig
  Eigen::Isometry3d T_ref_left_rect;   // left rectified frame in the rig frame
  Eigen::Isometry3d T_ref_right_rect;  // right rectified frame: same rotation, right centre
  double baseline_m = 0.0;
  camera::RectifiedCamera grid;  // the rectified image both eyes share
};

// Throws std::invalid_argument when the two cameras coincide.
StereoGeometry make_stereo_geometry(const camera::Rig& rig, const camera::StereoPair& pair,
                                    const camera::RectifiedIntrinsics& grid);

// A grid that keeps the raw camera's centre resolution (f = the model's paraxial px per rad)
// over `width` columns, with the height covering the same vertical field as the raw image
// (equirectangular, centred).
camera::RectifiedIntrinsics grid_matching_camera(const camera::RigCamera& raw, int width);

// The default grid of a stereo pair (used by `thermovis rectify` and the pipeline): the left
// camera's centre resolution (f of grid_matching_camera), and the bounding box, in the shared
// rectified frame, of both eyes' left/right image edges (middle tenth of their rows) and
// top/bottom edges (middle tenth of their columns): each eye's whole horizontal and vertical
// field along its centre lines is kept (the fisheye corners reach farther and are cut). The eyes
// are rotated differently from the rectified frame (the paper's visible pair by about 7 and 3
// deg of yaw), so the box, and (cx, cy), are not centred. Sizes are rounded up to even.
camera::RectifiedIntrinsics default_pair_grid(
    const camera::Rig& rig, const camera::StereoPair& pair,
    camera::RectifiedProjection projection = camera::RectifiedProjection::equirectangular);

// For every pixel of `grid` seen from the rectified frame T_ref_rect, the raw pixel of `camera`
// (CV_32FC2: x = column, y = row) that sees the same scene point. Points are taken at
// `registration_distance_m` from the rectified frame's origin; <= 0 means at infinity (pure
// rotation, exact for the camera whose centre is that origin). Pixels with no valid ray get
// (-1, -1). Computed in parallel over rows (cv::parallel_for_). `roi` restricts the map to part of
// the grid (the map then has the roi's size).
cv::Mat build_map(const camera::RigCamera& camera, const Eigen::Isometry3d& T_ref_rect,
                  const camera::RectifiedCamera& grid, double registration_distance_m = 0.0,
                  cv::Rect roi = {});

// `map` (build_map's) made for the camera's image binned by `bin` (bin x bin pixels averaged):
// a raw pixel centre x is the binned image's (x + 0.5) / bin - 0.5; (-1, -1) entries stay.
void bin_map(cv::Mat& map, int bin);

// A box of a raw image of `camera` ([x_min, y_min, x_max, y_max] px) on `grid` seen from the
// rectified frame T_ref_rect: the bounding box of its border's rays, rotated into that frame (at
// infinity). Empty when none reaches the grid.
cv::Rect raw_box_on_grid(const camera::RigCamera& camera, const Eigen::Isometry3d& T_ref_rect,
                         const camera::RectifiedCamera& grid, double x_min, double y_min,
                         double x_max, double y_max);

// The pixel box on `grid` holding the projections of rays (or points) of the grid's rectified
// frame; those outside the grid's domain are left out. Empty when none projects.
cv::Rect rays_box_on_grid(const camera::RectifiedCamera& grid,
                          const std::vector<Eigen::Vector3d>& rays);

}  // namespace thermovis::rectify
