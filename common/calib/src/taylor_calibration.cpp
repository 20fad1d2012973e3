#include "thermovis/calib/taylor_calibration.hpp"

#include <ceres/ceres.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "taylor_projection.hpp"

namespace thermovis::calib {

namespace detail {

std::vector<double> pack_intrinsics(const camera::TaylorIntrinsics& in, double radius_scale) {
  std::vector<double> p(kIntrinsicsSize, 0.0);
  p[0] = in.xc;
  p[1] = in.yc;
  p[2] = in.c;
  p[3] = 0.5 * (in.d + in.e);
  p[4] = in.pol.at(0);
  for (size_t k = 2; k < in.pol.size() && k <= static_cast<size_t>(kMaxDegree); ++k)
    p[4 + k - 1] = in.pol[k] * std::pow(radius_scale, static_cast<double>(k));
  return p;
}

camera::TaylorIntrinsics unpack_intrinsics(const double* intr, double radius_scale,
                                           int polynomial_degree, cv::Size image_size) {
  camera::TaylorIntrinsics out;
  out.width = image_size.width;
  out.height = image_size.height;
  out.xc = intr[0];
  out.yc = intr[1];
  out.c = intr[2];
  out.d = intr[3];
  out.e = intr[3];
  out.pol.assign(static_cast<size_t>(polynomial_degree) + 1, 0.0);
  out.pol[0] = intr[4];
  for (int k = 2; k <= polynomial_degree; ++k)
    out.pol[static_cast<size_t>(k)] = intr[4 + k - 1] / std::pow(radius_scale, k);
  return out;
}

void pack_pose(const Eigen::Isometry3d& T, double* pose) {
  const Eigen::AngleAxisd aa(T.rotation());
  const Eigen::Vector3d v = aa.axis() * aa.angle();
  for (int i = 0; i < 3; ++i) {
    pose[i] = v[i];
    pose[3 + i] = T.translation()[i];
  }
}

Eigen::Isometry3d unpack_pose(const double* pose) {
  const Eigen::Vector3d v(pose[0], pose[1], pose[2]);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double angle = v.norm();
  if (angle > 0) T.linear() = Eigen::AngleAxisd(angle, v / angle).toRotationMatrix();
  T.translation() = Eigen::Vector3d(pose[3], pose[4], pose[5]);
  return T;
}

}  // namespace detail

namespace {

using detail::kIntrinsicsSize;
using detail::kPoseSize;

// OCamCalib's frame (u = row, v = column, w = -forward) to ours (x = column, y = row, z fwd).
Eigen::Matrix3d ocam_to_camera() {
  Eigen::Matrix3d m;
  m << 0, 1, 0, 1, 0, 0, 0, 0, -1;
  return m;
}

// A linear solution: intrinsics block and poses (our camera frame).
struct LinearSolution {
  std::vector<double> intrinsics;
  std::vector<std::array<double, kPoseSize>> poses;
  double rms_2d_px = std::numeric_limits<double>::infinity();
};

struct ExtrinsicCandidate {
  Eigen::Matrix3d R_ocam;  // columns r1 r2 r3
  double t1 = 0, t2 = 0;
};

// The two candidate partial extrinsics of one view (centre already subtracted: uv = (u, v)).
bool partial_extrinsics(const std::vector<Eigen::Vector3d>& board,
                        const std::vector<Eigen::Vector2d>& uv,
                        std::array<ExtrinsicCandidate, 2>& out) {
  const int n = static_cast<int>(board.size());
  Eigen::MatrixXd M(n, 6);
  for (int j = 0; j < n; ++j) {
    const double X = board[static_cast<size_t>(j)].x(), Y = board[static_cast<size_t>(j)].y();
    const double u = uv[static_cast<size_t>(j)].x(), v = uv[static_cast<size_t>(j)].y();
    M.row(j) << -v * X, -v * Y, u * X, u * Y, -v, u;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  if (!(sv(4) > 1e-9 * sv(0))) return false;  // null space not unique: board seen edge-on
  Eigen::Matrix<double, 6, 1> h = svd.matrixV().col(5);
  // Sign: lambda * (u, v) = (r11 X + r12 Y + t1, r21 X + r22 Y + t2) with lambda > 0.
  double agreement = 0.0;
  for (int j = 0; j < n; ++j) {
    const double X = board[static_cast<size_t>(j)].x(), Y = board[static_cast<size_t>(j)].y();
    agreement += uv[static_cast<size_t>(j)].x() * (h[0] * X + h[1] * Y + h[4]) +
                 uv[static_cast<size_t>(j)].y() * (h[2] * X + h[3] * Y + h[5]);
  }
  if (agreement < 0) h = -h;
  const double r11 = h[0], r12 = h[1], r21 = h[2], r22 = h[3];
  const double B = r11 * r12 + r21 * r22;
  const double D = (r12 * r12 + r22 * r22) - (r11 * r11 + r21 * r21);
  const double r31_sq = 0.5 * (D + std::sqrt(D * D + 4 * B * B));
  for (int k = 0; k < 2; ++k) {
    double r31, r32;
    if (r31_sq > 1e-14 * (r11 * r11 + r21 * r21 + r12 * r12 + r22 * r22)) {
      r31 = (k == 0 ? 1 : -1) * std::sqrt(r31_sq);
      r32 = -B / r31;
    } else {
      r31 = 0.0;
      r32 = (k == 0 ? 1 : -1) * std::sqrt(std::max(0.0, -D));
    }
    const Eigen::Vector3d r1(r11, r21, r31), r2(r12, r22, r32);
    const double scale = 1.0 / r1.norm();
    out[static_cast<size_t>(k)].R_ocam.col(0) = r1 * scale;
    out[static_cast<size_t>(k)].R_ocam.col(1) = r2 * scale;
    out[static_cast<size_t>(k)].R_ocam.col(2) = (r1 * scale).cross(r2 * scale);
    out[static_cast<size_t>(k)].t1 = h[4] * scale;
    out[static_cast<size_t>(k)].t2 = h[5] * scale;
  }
  return true;
}

// Solves the polynomial (normalised b0, b2..bN) and each view's t3 by linear least squares.
// Returns false when the system is rank deficient.
bool solve_polynomial(const std::vector<std::vector<Eigen::Vector3d>>& boards,
                      const std::vector<std::vector<Eigen::Vector2d>>& uv,
                      const std::vector<const ExtrinsicCandidate*>& ext, int degree,
                      double radius_scale, std::vector<double>& b, std::vector<double>& t3,
                      double* residual_rms = nullptr) {
  const int views = static_cast<int>(uv.size());
  const int npoly = degree;  // b0, b2..bN
  const int unknowns = npoly + views;
  int total = 0;
  for (const auto& b_i : boards) total += static_cast<int>(b_i.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * total, unknowns);
  Eigen::VectorXd rhs(2 * total);
  int row = 0;
  for (int i = 0; i < views; ++i) {
    const auto& R = ext[static_cast<size_t>(i)]->R_ocam;
    const auto& board = boards[static_cast<size_t>(i)];
    const int n = static_cast<int>(board.size());
    for (int j = 0; j < n; ++j, row += 2) {
      const double X = board[static_cast<size_t>(j)].x(), Y = board[static_cast<size_t>(j)].y();
      const double u = uv[static_cast<size_t>(i)][static_cast<size_t>(j)].x();
      const double v = uv[static_cast<size_t>(i)][static_cast<size_t>(j)].y();
      const double rho = std::hypot(u, v) / radius_scale;
      const double Aj = R(1, 0) * X + R(1, 1) * Y + ext[static_cast<size_t>(i)]->t2;
      const double Cj = R(0, 0) * X + R(0, 1) * Y + ext[static_cast<size_t>(i)]->t1;
      const double third = R(2, 0) * X + R(2, 1) * Y;
      double power = 1.0;
      for (int k = 0; k < npoly; ++k) {
        A(row, k) = Aj * power;
        A(row + 1, k) = Cj * power;
        power *= (k == 0) ? rho * rho : rho;
      }
      A(row, npoly + i) = -v;
      A(row + 1, npoly + i) = -u;
      rhs(row) = v * third;
      rhs(row + 1) = u * third;
    }
  }
  // Column scaling for conditioning.
  Eigen::VectorXd col_scale = A.colwise().norm().transpose();
  for (int k = 0; k < unknowns; ++k) {
    if (!(col_scale(k) > 0)) return false;
    A.col(k) /= col_scale(k);
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  qr.setThreshold(1e-10);
  if (qr.rank() < unknowns) return false;
  Eigen::VectorXd x = qr.solve(rhs);
  if (residual_rms) *residual_rms = std::sqrt((A * x - rhs).squaredNorm() / rhs.size());
  x = x.cwiseQuotient(col_scale);
  b.assign(x.data(), x.data() + npoly);
  t3.assign(x.data() + npoly, x.data() + unknowns);
  return std::all_of(x.data(), x.data() + unknowns, [](double a) { return std::isfinite(a); });
}

double rms_of(const std::vector<double>& intr, double radius_scale,
              const std::vector<std::array<double, kPoseSize>>& poses,
              const std::vector<Eigen::Vector3d>& board, const std::vector<View>& views,
              const std::vector<int>& which) {
  double sum = 0.0;
  int count = 0;
  for (int i : which) {
    for (size_t j = 0; j < board.size(); ++j) {
      detail::CornerResidual res{board[j], views[static_cast<size_t>(i)].corners[j], radius_scale};
      double r[2];
      // A corner the model cannot project (a poor linear solution) costs a fixed 100 px, so
      // solutions stay comparable during the centre search.
      if (res(intr.data(), poses[static_cast<size_t>(i)].data(), r))
        sum += r[0] * r[0] + r[1] * r[1];
      else
        sum += 1e4;
      ++count;
    }
  }
  return std::sqrt(sum / count);
}

// OCamCalib's linear solution for a centre (row, column), c = 1, d = e = 0.
LinearSolution linear_solution(const std::vector<Eigen::Vector3d>& board,
                               const std::vector<View>& views, const std::vector<int>& which,
                               double xc, double yc, int degree, double radius_scale) {
  LinearSolution sol;
  std::vector<std::vector<Eigen::Vector2d>> uv;
  std::vector<std::vector<Eigen::Vector3d>> boards;
  std::vector<std::array<ExtrinsicCandidate, 2>> candidates;
  for (int i : which) {
    std::vector<Eigen::Vector2d> centred;
    std::vector<Eigen::Vector3d> seen;
    const auto& corners = views[static_cast<size_t>(i)].corners;
    for (size_t j = 0; j < corners.size(); ++j) {
      if (!corners[j].allFinite()) continue;
      centred.emplace_back(corners[j].y() - xc, corners[j].x() - yc);
      seen.push_back(board[j]);
    }
    std::array<ExtrinsicCandidate, 2> cand;
    if (!partial_extrinsics(seen, centred, cand)) return sol;
    uv.push_back(std::move(centred));
    boards.push_back(std::move(seen));
    candidates.push_back(cand);
  }
  // Each view's tilt sign: the candidate whose single-view polynomial fit is best (a0 < 0).
  std::vector<const ExtrinsicCandidate*> chosen;
  const int single_degree = std::min(degree, 3);
  for (size_t i = 0; i < uv.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    const ExtrinsicCandidate* pick = &candidates[i][0];
    for (const auto& cand : candidates[i]) {
      std::vector<double> b, t3;
      double residual = 0.0;
      if (!solve_polynomial({boards[i]}, {uv[i]}, {&cand}, single_degree, radius_scale, b, t3,
                            &residual))
        continue;
      if (b[0] >= 0) residual += 1e6;
      if (residual < best) {
        best = residual;
        pick = &cand;
      }
    }
    chosen.push_back(pick);
  }
  std::vector<double> b, t3;
  if (!solve_polynomial(boards, uv, chosen, degree, radius_scale, b, t3)) return sol;
  if (!(b[0] < 0)) return sol;
  sol.intrinsics.assign(kIntrinsicsSize, 0.0);
  sol.intrinsics[0] = xc;
  sol.intrinsics[1] = yc;
  sol.intrinsics[2] = 1.0;
  sol.intrinsics[3] = 0.0;
  for (int k = 0; k < degree; ++k)
    sol.intrinsics[static_cast<size_t>(4 + k)] = b[static_cast<size_t>(k)];
  const Eigen::Matrix3d M = ocam_to_camera();
  sol.poses.assign(views.size(), {});
  for (size_t i = 0; i < which.size(); ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    Eigen::Matrix3d R = chosen[i]->R_ocam;
    // Nearest rotation (the linear estimate is only close to orthonormal).
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    R = svd.matrixU() * svd.matrixV().transpose();
    T.linear() = M * R;
    T.translation() = M * Eigen::Vector3d(chosen[i]->t1, chosen[i]->t2, t3[i]);
    detail::pack_pose(T, sol.poses[static_cast<size_t>(which[i])].data());
  }
  sol.rms_2d_px = rms_of(sol.intrinsics, radius_scale, sol.poses, board, views, which);
  return sol;
}

// Coarse-to-fine grid search of the centre (OCamCalib's findcenter).
LinearSolution search_centre(const std::vector<Eigen::Vector3d>& board,
                             const std::vector<View>& views, const std::vector<int>& which,
                             cv::Size image_size, int degree, double radius_scale) {
  double xc = 0.5 * (image_size.height - 1), yc = 0.5 * (image_size.width - 1);
  LinearSolution best = linear_solution(board, views, which, xc, yc, degree, radius_scale);
  double half_range = 0.15 * std::min(image_size.width, image_size.height);
  const int steps = 4;  // grid of (2 steps + 1)^2
  for (int round = 0; round < 5; ++round) {
    const double cx = xc, cy = yc;
    for (int a = -steps; a <= steps; ++a) {
      for (int bb = -steps; bb <= steps; ++bb) {
        const double r = cx + half_range * a / steps, c = cy + half_range * bb / steps;
        LinearSolution s = linear_solution(board, views, which, r, c, degree, radius_scale);
        if (s.rms_2d_px < best.rms_2d_px) {
          best = std::move(s);
          xc = r;
          yc = c;
        }
      }
    }
    half_range /= steps;
  }
  return best;
}

void check_views(const std::vector<View>& views, const BoardSpec& board, cv::Size image_size) {
  if (board.inner_corners.width < 2 || board.inner_corners.height < 2 || !(board.square_mm > 0))
    throw std::invalid_argument(
        "calibration: board needs at least 2x2 inner corners and a "
        "positive square size");
  if (image_size.width <= 0 || image_size.height <= 0)
    throw std::invalid_argument("calibration: image size must be positive");
  if (views.size() < 3)
    throw std::invalid_argument("calibration: " + std::to_string(views.size()) +
                                " usable views; at least 3 are needed");
  for (const auto& v : views) {
    if (static_cast<int>(v.corners.size()) != board.corner_count())
      throw std::invalid_argument("calibration: view " + v.name + " has " +
                                  std::to_string(v.corners.size()) + " corners, the " +
                                  std::to_string(board.inner_corners.width) + "x" +
                                  std::to_string(board.inner_corners.height) + " board has " +
                                  std::to_string(board.corner_count()));
    const auto seen = std::count_if(v.corners.begin(), v.corners.end(),
                                    [](const Eigen::Vector2d& p) { return p.allFinite(); });
    if (2 * seen < static_cast<long>(v.corners.size()))
      throw std::invalid_argument("calibration: view " + v.name + " has only " +
                                  std::to_string(seen) + " of its corners");
  }
}

}  // namespace

bool project_board_point(const camera::TaylorCamera& camera, const Eigen::Isometry3d& T_cam_board,
                         const Eigen::Vector3d& board_point, Eigen::Vector2d& pixel) {
  return camera.project(T_cam_board * board_point, pixel);
}

std::vector<double> reprojection_errors(const camera::TaylorCamera& camera,
                                        const Eigen::Isometry3d& T_cam_board,
                                        const BoardSpec& board, const View& view) {
  const auto pts = board.points();
  std::vector<double> err(pts.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t j = 0; j < pts.size() && j < view.corners.size(); ++j) {
    if (!view.corners[j].allFinite()) continue;
    Eigen::Vector2d px;
    if (project_board_point(camera, T_cam_board, pts[j], px))
      err[j] = (px - view.corners[j]).norm();
  }
  return err;
}

namespace detail {

// Adds the corner residuals of one view to a problem.
void add_view(ceres::Problem& problem, const std::vector<Eigen::Vector3d>& board, const View& view,
              double radius_scale, double robust_loss_px, double* intr, double* pose) {
  for (size_t j = 0; j < board.size(); ++j) {
    if (!view.corners[j].allFinite()) continue;  // not seen
    auto* cost = new ceres::AutoDiffCostFunction<CornerResidual, 2, kIntrinsicsSize, kPoseSize>(
        new CornerResidual{board[j], view.corners[j], radius_scale});
    ceres::LossFunction* loss = robust_loss_px > 0 ? new ceres::HuberLoss(robust_loss_px) : nullptr;
    problem.AddResidualBlock(cost, loss, intr, pose);
  }
}

// Holds the unused polynomial slots (and optionally the centre) constant.
void constrain_intrinsics(ceres::Problem& problem, double* intr, int degree, bool refine_centre) {
  std::vector<int> fixed;
  if (!refine_centre) fixed = {0, 1};
  for (int k = degree; k < kCoefficientSlots; ++k) fixed.push_back(4 + k);
  if (!fixed.empty()) problem.SetManifold(intr, new ceres::SubsetManifold(kIntrinsicsSize, fixed));
}

ceres::Solver::Options solver_options(int threads) {
  ceres::Solver::Options o;
  o.minimizer_type = ceres::TRUST_REGION;
  o.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  o.linear_solver_type = ceres::DENSE_SCHUR;
  o.max_num_iterations = 200;
  o.function_tolerance = 1e-12;
  o.gradient_tolerance = 1e-12;
  o.parameter_tolerance = 1e-12;
  o.num_threads = std::max(1, threads);
  o.logging_type = ceres::SILENT;
  return o;
}

}  // namespace detail

namespace {

// One refinement round over the views added to `problem` (the intrinsics' unused slots, and
// the centre unless refined, held constant); adds its iterations to `out`.
void refine_round(ceres::Problem& problem, double* intr, int degree,
                  const TaylorCalibrationOptions& options, TaylorCalibration& out) {
  detail::constrain_intrinsics(problem, intr, degree, options.refine_centre);
  ceres::Solver::Summary summary;
  ceres::Solve(detail::solver_options(options.threads), &problem, &summary);
  out.iterations += static_cast<int>(summary.iterations.size());
  if (!summary.IsSolutionUsable())
    throw std::runtime_error("calibration: refinement failed: " + summary.message);
}

}  // namespace

TaylorCalibration calibrate_taylor(const std::vector<View>& views, const BoardSpec& board,
                                   cv::Size image_size, const TaylorCalibrationOptions& options) {
  check_views(views, board, image_size);
  const int degree = options.polynomial_degree;
  if (degree < 2 || degree > detail::kMaxDegree)
    throw std::invalid_argument("calibration: polynomial degree must be 2.." +
                                std::to_string(detail::kMaxDegree));
  const auto pts = board.points();
  const double radius_scale = 0.5 * std::min(image_size.width, image_size.height);

  std::vector<int> used(views.size());
  for (size_t i = 0; i < views.size(); ++i) used[i] = static_cast<int>(i);

  LinearSolution lin = search_centre(pts, views, used, image_size, degree, radius_scale);
  if (!std::isfinite(lin.rms_2d_px))
    throw std::runtime_error(
        "calibration: no linear solution (degenerate views: boards seen edge-on or all "
        "parallel to the image, or corners in the wrong order)");

  TaylorCalibration out;
  out.linear_rms_2d_px = lin.rms_2d_px;
  std::vector<double> intr = lin.intrinsics;
  auto poses = lin.poses;

  // Corners left out of the final fit (robust outliers), per view.
  std::vector<View> fitted = views;
  if (options.refine) {
    for (int round = 0; round < 3; ++round) {
      ceres::Problem problem;
      for (int i : used)
        detail::add_view(problem, pts, views[static_cast<size_t>(i)], radius_scale,
                         options.robust_loss_px, intr.data(), poses[static_cast<size_t>(i)].data());
      refine_round(problem, intr.data(), degree, options, out);
      // Outlier views: far above the others.
      std::vector<double> rms;
      for (int i : used) rms.push_back(rms_of(intr, radius_scale, poses, pts, views, {i}));
      std::vector<double> sorted = rms;
      std::sort(sorted.begin(), sorted.end());
      const double limit = std::max(options.outlier_view_rms_px, 4.0 * sorted[sorted.size() / 2]);
      std::vector<int> kept;
      for (size_t k = 0; k < used.size(); ++k)
        if (rms[k] <= limit) kept.push_back(used[k]);
      if (kept.size() == used.size() || kept.size() < 3) break;
      used = kept;
    }
    // Final plain least-squares polish over the inlier corners (error under
    // max(outlier_corner_px, 5 x RMS) after the robust fit): the robust loss has done its job of
    // finding outliers, and the result then minimises the RMS it reports.
    if (options.robust_loss_px > 0) {
      const double rms_all = rms_of(intr, radius_scale, poses, pts, views, used);
      const double corner_limit = std::max(options.outlier_corner_px, 5.0 * rms_all);
      ceres::Problem problem;
      for (int i : used) {
        auto& view = fitted[static_cast<size_t>(i)];
        for (size_t j = 0; j < pts.size(); ++j) {
          if (!view.corners[j].allFinite()) continue;
          detail::CornerResidual res{pts[j], view.corners[j], radius_scale};
          double r[2];
          if (!res(intr.data(), poses[static_cast<size_t>(i)].data(), r) ||
              std::hypot(r[0], r[1]) > corner_limit) {
            view.corners[j] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
            ++out.corners_rejected;
          }
        }
        detail::add_view(problem, pts, view, radius_scale, 0.0, intr.data(),
                         poses[static_cast<size_t>(i)].data());
      }
      refine_round(problem, intr.data(), degree, options, out);
    }
  }

  out.intrinsics = detail::unpack_intrinsics(intr.data(), radius_scale, degree, image_size);
  if (!(out.intrinsics.pol[0] < 0))
    throw std::runtime_error("calibration: the refinement ended with a0 >= 0 (degenerate views)");
  const camera::TaylorCamera cam(out.intrinsics);  // validates and fits invpol
  out.intrinsics = cam.intrinsics();

  double sum = 0.0;
  int count = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    ViewError ve;
    ve.name = views[i].name;
    ve.used = std::find(used.begin(), used.end(), static_cast<int>(i)) != used.end();
    ve.T_cam_board = detail::unpack_pose(poses[i].data());
    double s = 0.0;
    int nvalid = 0;
    const auto errors = reprojection_errors(cam, ve.T_cam_board, board, fitted[i]);
    for (size_t j = 0; j < errors.size(); ++j) {
      if (!fitted[i].corners[j].allFinite()) continue;  // not seen or rejected
      // Seen but not projectable counts as infinitely wrong.
      const double e =
          std::isfinite(errors[j]) ? errors[j] : std::numeric_limits<double>::infinity();
      s += e * e;
      ++nvalid;
      ve.max_px = std::max(ve.max_px, e);
    }
    ve.rms_2d_px = std::sqrt(s / nvalid);
    if (ve.used) {
      sum += s;
      count += nvalid;
    }
    out.views.push_back(ve);
  }
  out.images_used = static_cast<int>(used.size());
  out.corners_used = count;
  out.rms_2d_px = std::sqrt(sum / count);
  if (!std::isfinite(out.rms_2d_px))
    throw std::runtime_error("calibration: some corners cannot be projected with the result");
  return out;
}

}  // namespace thermovis::calib
