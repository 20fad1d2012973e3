#pragma once
// Mono calibration of the Taylor (OCamCalib) camera model from checkerboard views.
//
// 1. Linear initialisation (Scaramuzza, Martinelli, Siegwart 2006), for a given centre with
//    c = 1, d = e = 0: per view, the extrinsic r11 r12 r21 r22 t1 t2 from the null space of the
//    equations that do not involve the polynomial (SVD), r31 r32 and the scale from the
//    orthonormality of r1, r2; then the polynomial a0, a2..aN and every view's t3 by one linear
//    least-squares problem. The centre is found by a coarse-to-fine grid search minimising the
//    reprojection RMS of that linear solution.
// 2. Joint refinement (Ceres, Levenberg-Marquardt, robust loss on each corner's 2-D residual)
//    of all intrinsics (a0, a2..aN, centre, c, d, e) and all board poses, minimising the
//    reprojection error in the image (world2cam solved exactly, not through invpol).
//    Rotation gauge: the antisymmetric part of [[c, d], [e, 1]] is, to first order, an image
//    rotation that the board poses absorb exactly (the model is radially symmetric), so it is
//    pinned: d = e is estimated as one parameter. Views whose error stays far above the rest
//    (wrong detections) are dropped and the refinement repeated; then corners whose error is
//    far above the RMS (occluded or mislocated) are left out and a last plain least-squares
//    round minimises exactly the RMS that is reported.
//
// Errors: rms_2d_px = sqrt(mean over all corners of |observed - projected|^2), the 2-D
// (Euclidean) distance in px; OCamCalib's own "rms". Urban 2015's "rms" is per coordinate
// (= rms_2d_px / sqrt(2)).
#include <Eigen/Geometry>
#include <opencv2/core/types.hpp>
#include <string>
#include <vector>

#include "thermovis/calib/board.hpp"
#include "thermovis/camera/taylor.hpp"

namespace thermovis::calib {

struct TaylorCalibrationOptions {
  int polynomial_degree = 4;         // a0, a2..a_degree (a1 = 0)
  double robust_loss_px = 1.0;       // Huber scale on the 2-D residual, px; 0 = plain least squares
  bool refine = true;                // false: linear initialisation only
  bool refine_centre = true;         // false: keep the centre of the linear search
  double outlier_view_rms_px = 3.0;  // drop views with rms over max(this, 4 x median)
  double outlier_corner_px = 2.0;    // leave out corners with error over max(this, 5 x RMS)
  int threads = 1;                   // Ceres threads
};

struct ViewError {
  std::string name;
  bool used = true;        // false: dropped as an outlier (its figures are still reported)
  double rms_2d_px = 0.0;  // this view's 2-D RMS, px
  double max_px = 0.0;     // its largest corner error, px
  // Board pose: p_cam = T_cam_board * p_board, mm; camera frame x right, y down, z forward
  // (camera_model.hpp), board frame as board.hpp.
  Eigen::Isometry3d T_cam_board = Eigen::Isometry3d::Identity();
};

struct TaylorCalibration {
  camera::TaylorIntrinsics intrinsics;  // invpol fitted by TaylorCamera
  std::vector<ViewError> views;         // in input order
  int images_used = 0;
  int corners_used = 0;
  int corners_rejected = 0;       // robust outliers left out of the final fit and the RMS
  double rms_2d_px = 0.0;         // over the corners of used views (definition above)
  double linear_rms_2d_px = 0.0;  // of the linear initialisation, same views
  int iterations = 0;             // Ceres iterations (all rounds)
};

// Throws std::invalid_argument for fewer than 3 views, views whose corner count differs from
// the board's, non-finite corners; std::runtime_error (naming the cause) when the views are
// degenerate (e.g. all boards parallel to the image, so the polynomial is not determined) or
// the refinement diverges.
TaylorCalibration calibrate_taylor(const std::vector<View>& views, const BoardSpec& board,
                                   cv::Size image_size,
                                   const TaylorCalibrationOptions& options = {});

// Reprojection of board points with a given model and pose; false where it is not defined.
bool project_board_point(const camera::TaylorCamera& camera, const Eigen::Isometry3d& T_cam_board,
                         const Eigen::Vector3d& board_point, Eigen::Vector2d& pixel);

// 2-D errors (px) of one view's corners under a model and pose (NaN where the corner is
// missing or not projectable).
std::vector<double> reprojection_errors(const camera::TaylorCamera& camera,
                                        const Eigen::Isometry3d& T_cam_board,
                                        const BoardSpec& board, const View& view);

}  // namespace thermovis::calib
