#include "thermovis/calib/stereo_calibration.hpp"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "taylor_projection.hpp"

namespace thermovis::calib {

namespace {

using detail::kIntrinsicsSize;
using detail::kPoseSize;

// Rotation average: the chordal L2 mean of the rotations (SVD projection of their sum).
Eigen::Isometry3d mean_pose(const std::vector<Eigen::Isometry3d>& poses) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const auto& T : poses) {
    sum += T.linear();
    t += T.translation();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1;
    R = U * svd.matrixV().transpose();
  }
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = R;
  out.translation() = t / static_cast<double>(poses.size());
  return out;
}

struct Problem {
  std::vector<Eigen::Vector3d> board;
  double left_scale = 0, right_scale = 0;
  std::vector<double> left_intr, right_intr;
  std::vector<std::array<double, kPoseSize>> board_poses;  // left camera <- board, per pair
  std::array<double, kPoseSize> right_left{};
};

// 2-D errors (px) of one pair's corners (left then right); throws std::runtime_error naming
// the pair where a corner is not projectable.
std::vector<double> pair_errors(const Problem& p, size_t pair, const View& l, const View& r) {
  const auto fail = [&l, &r] {
    return std::runtime_error("stereo calibration: a corner of pair " + l.name + " / " + r.name +
                              " cannot be projected");
  };
  std::vector<double> errors;
  for (size_t j = 0; j < p.board.size(); ++j) {
    double res[2];
    if (l.corners[j].allFinite()) {
      detail::CornerResidual c{p.board[j], l.corners[j], p.left_scale};
      if (!c(p.left_intr.data(), p.board_poses[pair].data(), res)) throw fail();
      errors.push_back(std::hypot(res[0], res[1]));
    }
    if (r.corners[j].allFinite()) {
      detail::SecondCameraCornerResidual c{{p.board[j], r.corners[j], p.right_scale}};
      if (!c(p.right_intr.data(), p.board_poses[pair].data(), p.right_left.data(), res))
        throw fail();
      errors.push_back(std::hypot(res[0], res[1]));
    }
  }
  return errors;
}

void solve(Problem& p, const std::vector<View>& left, const std::vector<View>& right,
           const std::vector<size_t>& used, int degree, double robust_loss_px, int threads) {
  ceres::Problem problem;
  for (size_t i : used) {
    for (size_t j = 0; j < p.board.size(); ++j) {
      ceres::LossFunction* loss_l =
          robust_loss_px > 0 ? new ceres::HuberLoss(robust_loss_px) : nullptr;
      ceres::LossFunction* loss_r =
          robust_loss_px > 0 ? new ceres::HuberLoss(robust_loss_px) : nullptr;
      if (left[i].corners[j].allFinite()) {
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<detail::CornerResidual, 2, kIntrinsicsSize, kPoseSize>(
                new detail::CornerResidual{p.board[j], left[i].corners[j], p.left_scale}),
            loss_l, p.left_intr.data(), p.board_poses[i].data());
      } else {
        delete loss_l;
      }
      if (right[i].corners[j].allFinite()) {
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<detail::SecondCameraCornerResidual, 2, kIntrinsicsSize,
                                            kPoseSize, kPoseSize>(
                new detail::SecondCameraCornerResidual{
                    {p.board[j], right[i].corners[j], p.right_scale}}),
            loss_r, p.right_intr.data(), p.board_poses[i].data(), p.right_left.data());
      } else {
        delete loss_r;
      }
    }
  }
  detail::constrain_intrinsics(problem, p.left_intr.data(), degree, true);
  detail::constrain_intrinsics(problem, p.right_intr.data(), degree, true);
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(threads), &problem, &summary);
  if (!summary.IsSolutionUsable())
    throw std::runtime_error("stereo calibration: refinement failed: " + summary.message);
}

}  // namespace

StereoCalibration calibrate_stereo(const std::vector<View>& left, const std::vector<View>& right,
                                   const BoardSpec& board, cv::Size left_size, cv::Size right_size,
                                   const TaylorCalibrationOptions& options) {
  if (left.size() != right.size())
    throw std::invalid_argument("stereo calibration: " + std::to_string(left.size()) +
                                " left views but " + std::to_string(right.size()) + " right");
  if (left.size() < 3)
    throw std::invalid_argument("stereo calibration: " + std::to_string(left.size()) +
                                " usable pairs; at least 3 are needed");
  StereoCalibration out;
  out.left = calibrate_taylor(left, board, left_size, options);
  out.right = calibrate_taylor(right, board, right_size, options);

  Problem p;
  p.board = board.points();
  p.left_scale = 0.5 * std::min(left_size.width, left_size.height);
  p.right_scale = 0.5 * std::min(right_size.width, right_size.height);
  p.left_intr = detail::pack_intrinsics(out.left.intrinsics, p.left_scale);
  p.right_intr = detail::pack_intrinsics(out.right.intrinsics, p.right_scale);
  // The relative pose from the pairs good in both cameras; then every pair good in at least
  // one camera takes part (its board pose from that camera), so a view that the other
  // camera's mono fit lost to a local minimum is recovered through the relative pose.
  std::vector<Eigen::Isometry3d> relative;
  for (size_t i = 0; i < left.size(); ++i)
    if (out.left.views[i].used && out.right.views[i].used)
      relative.push_back(out.right.views[i].T_cam_board * out.left.views[i].T_cam_board.inverse());
  if (relative.size() < 3)
    throw std::runtime_error("stereo calibration: only " + std::to_string(relative.size()) +
                             " pairs are good in both cameras; at least 3 are needed");
  const Eigen::Isometry3d T_right_left = mean_pose(relative);
  detail::pack_pose(T_right_left, p.right_left.data());
  std::vector<size_t> used;
  p.board_poses.resize(left.size());
  for (size_t i = 0; i < left.size(); ++i) {
    if (out.left.views[i].used) {
      detail::pack_pose(out.left.views[i].T_cam_board, p.board_poses[i].data());
    } else if (out.right.views[i].used) {
      detail::pack_pose(T_right_left.inverse() * out.right.views[i].T_cam_board,
                        p.board_poses[i].data());
    } else {
      continue;
    }
    used.push_back(i);
  }

  const int degree = options.polynomial_degree;
  solve(p, left, right, used, degree, options.robust_loss_px, options.threads);

  // Leave out corners far above the RMS, then a plain least-squares polish (as in mono).
  std::vector<View> l_fit = left, r_fit = right;
  if (options.robust_loss_px > 0) {
    double sum = 0;
    size_t count = 0;
    for (size_t i : used) {
      const std::vector<double> e = pair_errors(p, i, left[i], right[i]);
      for (double x : e) sum += x * x;
      count += e.size();
    }
    const double limit = std::max(options.outlier_corner_px, 5.0 * std::sqrt(sum / count));
    for (size_t i : used) {
      for (size_t j = 0; j < p.board.size(); ++j) {
        double res[2];
        if (l_fit[i].corners[j].allFinite()) {
          detail::CornerResidual c{p.board[j], l_fit[i].corners[j], p.left_scale};
          if (!c(p.left_intr.data(), p.board_poses[i].data(), res) ||
              std::hypot(res[0], res[1]) > limit) {
            l_fit[i].corners[j] = Eigen::Vector2d::Constant(std::nan(""));
            ++out.corners_rejected;
          }
        }
        if (r_fit[i].corners[j].allFinite()) {
          detail::SecondCameraCornerResidual c{{p.board[j], r_fit[i].corners[j], p.right_scale}};
          if (!c(p.right_intr.data(), p.board_poses[i].data(), p.right_left.data(), res) ||
              std::hypot(res[0], res[1]) > limit) {
            r_fit[i].corners[j] = Eigen::Vector2d::Constant(std::nan(""));
            ++out.corners_rejected;
          }
        }
      }
    }
    solve(p, l_fit, r_fit, used, degree, 0.0, options.threads);
  }

  out.left_intrinsics =
      camera::TaylorCamera(
          detail::unpack_intrinsics(p.left_intr.data(), p.left_scale, degree, left_size))
          .intrinsics();
  out.right_intrinsics =
      camera::TaylorCamera(
          detail::unpack_intrinsics(p.right_intr.data(), p.right_scale, degree, right_size))
          .intrinsics();
  out.T_right_left = detail::unpack_pose(p.right_left.data());
  double sum = 0;
  size_t count = 0;
  for (size_t i : used) {
    const std::vector<double> e = pair_errors(p, i, l_fit[i], r_fit[i]);
    double s = 0;
    for (double x : e) s += x * x;
    out.pairs.push_back({left[i].name, right[i].name, std::sqrt(s / e.size())});
    sum += s;
    count += e.size();
  }
  out.pairs_used = static_cast<int>(used.size());
  out.rms_2d_px = std::sqrt(sum / count);
  return out;
}

}  // namespace thermovis::calib
