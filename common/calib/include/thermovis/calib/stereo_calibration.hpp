#pragma once
// Stereo calibration of two Taylor cameras from paired checkerboard views.
//
// Each camera is first calibrated alone (calibrate_taylor, all its views). The relative pose is
// initialised from the paired views (median over pairs of T_right_board * T_left_board^-1),
// then refined jointly with Ceres (LM, robust loss, then a plain least-squares polish as in
// mono): one board pose per pair in the left camera, ONE relative pose right <- left, and both
// cameras' intrinsics (as in mono: d = e pinned).
//
// stereo rms_2d_px = sqrt(mean over every corner of both images of every used pair of the
// squared 2-D reprojection error), px.
#include <Eigen/Geometry>

#include "thermovis/calib/taylor_calibration.hpp"

namespace thermovis::calib {

struct StereoPairError {
  std::string left_name, right_name;
  double rms_2d_px = 0.0;  // over both images of the pair
};

struct StereoCalibration {
  TaylorCalibration left, right;  // the mono calibrations (before the joint refinement)
  camera::TaylorIntrinsics left_intrinsics, right_intrinsics;  // after the joint refinement
  // p_right = T_right_left * p_left; mm; camera frames of camera_model.hpp.
  Eigen::Isometry3d T_right_left = Eigen::Isometry3d::Identity();
  std::vector<StereoPairError> pairs;
  int pairs_used = 0;
  int corners_rejected = 0;
  double rms_2d_px = 0.0;
};

// left[i] and right[i] are the same board seen at the same time (corners in the same board
// order). Throws as calibrate_taylor does, and std::invalid_argument when fewer than 3 pairs.
StereoCalibration calibrate_stereo(const std::vector<View>& left, const std::vector<View>& right,
                                   const BoardSpec& board, cv::Size left_size, cv::Size right_size,
                                   const TaylorCalibrationOptions& options = {});

}  // namespace thermovis::calib
