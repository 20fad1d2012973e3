// The composed rectification maps of the paper rig, measured through the fixed-point tables:
// epipolar row agreement of both pairs, field kept, infrared-to-visible registration, and a
// rendered scene point landing at its rectified position.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <string>

#include "thermovis/fpga/fixed_map.hpp"
#include "thermovis/fpga/remap.hpp"
#include "thermovis/rectify/elliptical.hpp"
#include "thermovis/rectify/rig_rectification.hpp"
#include "thermovis/rectify/synthetic_view.hpp"
#include "thermovis/test/paper_rig.hpp"

namespace {

using namespace thermovis;

using test::paper_rig;

// The rig's maps, computed once for all tests (about a second).
const rectify::RigRectification& paper_maps() {
  static const rectify::RigRectification maps = rectify::rectify_rig(paper_rig());
  return maps;
}

// A map as the hardware holds it: the Q11.5 table, read back as positions.
cv::Mat as_table(const cv::Mat& map, const camera::RigCamera& cam) {
  return fpga::FixedPointMap::from_float(map, cam.model->image_size()).to_float();
}

// Bilinear sample of a CV_32FC2 map at grid position q (false outside or on invalid entries).
bool sample_map(const cv::Mat& map, const Eigen::Vector2d& q, Eigen::Vector2d& out) {
  const int u = static_cast<int>(std::floor(q.x())), v = static_cast<int>(std::floor(q.y()));
  if (u < 0 || v < 0 || u + 1 >= map.cols || v + 1 >= map.rows) return false;
  const double fx = q.x() - u, fy = q.y() - v;
  out.setZero();
  const double weights[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  const int du[4] = {0, 1, 0, 1}, dv[4] = {0, 0, 1, 1};
  for (int k = 0; k < 4; ++k) {
    const cv::Vec2f e = map.at<cv::Vec2f>(v + dv[k], u + du[k]);
    if (e[0] < 0.0f && e[1] < 0.0f) return false;
    out += weights[k] * Eigen::Vector2d(e[0], e[1]);
  }
  return true;
}

// The grid pixel whose map entry is the raw pixel `raw`: Newton on the interpolated table from
// the guess in q. False when it does not converge to 1e-4 px.
bool invert_map(const cv::Mat& map, const Eigen::Vector2d& raw, Eigen::Vector2d& q) {
  for (int i = 0; i < 20; ++i) {
    Eigen::Vector2d m, mx, my;
    if (!sample_map(map, q, m) || !sample_map(map, q + Eigen::Vector2d(0.25, 0), mx) ||
        !sample_map(map, q + Eigen::Vector2d(0, 0.25), my)) {
      return false;
    }
    const Eigen::Vector2d err = m - raw;
    if (err.norm() < 1e-4) return true;
    Eigen::Matrix2d J;
    J << (mx - m) / 0.25, (my - m) / 0.25;
    q -= J.inverse() * err;
  }
  return false;
}

struct RowAgreement {
  double rms_px = 0.0, max_px = 0.0;
  int points = 0;
};

// Known 3-D points over the whole shared field at several depths, projected through both raw
// camera models, found again in each eye's rectified grid through its (fixed-point) table: their
// rows must agree.
RowAgreement measure_rows(const rectify::RectifiedPair& pair, const camera::Rig& rig) {
  const auto& g = pair.geometry;
  const auto& left = rig.camera(g.left);
  const auto& right = rig.camera(g.right);
  const cv::Mat left_table = as_table(pair.left_map, left);
  const cv::Mat right_table = as_table(pair.right_map, right);
  const cv::Size size = g.grid.image_size();
  RowAgreement out;
  double sum2 = 0.0;
  for (double depth : {2.0, 5.0, 20.0, 100.0}) {
    for (int j = 1; j < 16; ++j) {
      for (int i = 1; i < 24; ++i) {
        // A direction of the left rectified grid, at `depth` m from the left centre.
        Eigen::Vector3d ray;
        if (!g.grid.unproject({size.width * i / 24.0, size.height * j / 16.0}, ray)) continue;
        const Eigen::Vector3d p_ref = g.T_ref_left_rect * (depth * ray);
        Eigen::Vector2d raw_l, raw_r, q_l, q_r;
        if (!left.model->project(left.T_ref_cam.inverse() * p_ref, raw_l) ||
            !right.model->project(right.T_ref_cam.inverse() * p_ref, raw_r) ||
            !left.model->in_image(raw_l, 2.0) || !right.model->in_image(raw_r, 2.0)) {
          continue;
        }
        // Analytic guesses, refined on the tables.
        if (!g.grid.project(g.T_ref_left_rect.inverse() * p_ref, q_l) ||
            !g.grid.project(g.T_ref_right_rect.inverse() * p_ref, q_r)) {
          continue;
        }
        Eigen::Vector2d found_l = q_l, found_r = q_r;
        if (!invert_map(left_table, raw_l, found_l) || !invert_map(right_table, raw_r, found_r)) {
          continue;
        }
        const double dy = found_l.y() - found_r.y();
        sum2 += dy * dy;
        out.max_px = std::max(out.max_px, std::abs(dy));
        ++out.points;
      }
    }
  }
  out.rms_px = std::sqrt(sum2 / std::max(1, out.points));
  return out;
}

// More than 600 points of the pair agree in row to 0.1 px RMS and 0.25 px at worst.
RowAgreement expect_rows_agree(const char* pair_name, const rectify::RectifiedPair& pair) {
  const RowAgreement r = measure_rows(pair, paper_rig());
  EXPECT_GT(r.points, 600);
  EXPECT_LT(r.rms_px, 0.1);
  EXPECT_LT(r.max_px, 0.25);
  std::cout << pair_name << " pair: " << r.points << " points, row difference RMS " << r.rms_px
            << " px, max " << r.max_px << " px\n";
  return r;
}

TEST(Rectification, VisiblePairRowsAgreeBelowATenthOfAPixel) {
  const RowAgreement r = expect_rows_agree("visible", paper_maps().visible);
  RecordProperty("visible_row_rms_px", std::to_string(r.rms_px));
}

TEST(Rectification, InfraredPairRowsAgreeBelowATenthOfAPixel) {
  expect_rows_agree("infrared", paper_maps().infrared);
}

TEST(Rectification, KeepsAtLeast120DegreesOfHorizontalField) {
  const auto& rig = paper_rig();
  const auto& maps = paper_maps();
  for (const auto* pair : {&maps.visible, &maps.infrared}) {
    const int centre_row = static_cast<int>(std::lround(pair->geometry.grid.intrinsics().cy));
    const double left =
        rectify::field_kept_deg(*rig.camera(pair->geometry.left).model, pair->left_map, centre_row);
    const double right = rectify::field_kept_deg(*rig.camera(pair->geometry.right).model,
                                                 pair->right_map, centre_row);
    EXPECT_GE(left, 120.0) << pair->geometry.left;
    EXPECT_GE(right, 120.0) << pair->geometry.right;
    EXPECT_GE(pair->geometry.grid.horizontal_field() * 180 / M_PI, 120.0);
    std::cout << pair->geometry.left << " " << left << " deg, " << pair->geometry.right << " "
              << right << " deg kept; grid " << pair->geometry.grid.image_size() << "\n";
  }
}

// The infrared camera of each eye registered on that eye's visible grid: a scene point lands
// where the registration geometry puts it (the point on the infrared ray at the registration
// distance from the visible eye), so at the registration distance on the visible camera's
// position, elsewhere off it by the parallax of the 60 mm offset (registration_parallax_px at
// the centre of the field).
TEST(Rectification, InfraredRegistersOnTheVisibleGridWithThePredictedParallax) {
  const auto& rig = paper_rig();
  const auto& g = paper_maps().visible.geometry;
  const auto& ir = rig.camera(rig.infrared.left);
  const double f = g.grid.intrinsics().f;
  const Eigen::Vector3d ir_centre = g.T_ref_left_rect.inverse() * ir.T_ref_cam.translation();
  for (double registration : {0.0, 10.0}) {
    const cv::Mat ir_table =
        as_table(rectify::build_map(ir, g.T_ref_left_rect, g.grid, registration), ir);
    for (double depth : {5.0, 10.0, 1000.0}) {
      double worst = 0.0, centre_shift = -1.0;
      int points = 0;
      for (int i = 1; i < 8; ++i) {
        for (int j = 1; j < 6; ++j) {
          // Grid position of a point for the visible eye, and where the infrared table puts it.
          const Eigen::Vector2d q(
              i == 4 ? g.grid.intrinsics().cx : g.grid.image_size().width * i / 8.0,
              j == 3 ? g.grid.intrinsics().cy : g.grid.image_size().height * j / 6.0);
          Eigen::Vector3d ray;
          ASSERT_TRUE(g.grid.unproject(q, ray));
          const Eigen::Vector3d p_rect = depth * ray;
          const Eigen::Vector3d p_ref = g.T_ref_left_rect * p_rect;
          Eigen::Vector2d raw;
          if (!ir.model->project(ir.T_ref_cam.inverse() * p_ref, raw) ||
              !ir.model->in_image(raw, 2.0)) {
            continue;
          }
          Eigen::Vector2d found = q;
          if (!invert_map(ir_table, raw, found)) continue;
          // Expected: the infrared ray's point at the registration distance from the eye.
          const Eigen::Vector3d u = (p_rect - ir_centre).normalized();
          Eigen::Vector3d assumed = u;  // at infinity: the direction alone
          if (registration > 0.0) {
            const double b = ir_centre.dot(u);
            const double s =
                -b + std::sqrt(b * b - ir_centre.squaredNorm() + registration * registration);
            assumed = ir_centre + s * u;
          }
          Eigen::Vector2d expected;
          ASSERT_TRUE(g.grid.project(assumed, expected));
          worst = std::max(worst, (found - expected).norm());
          if (i == 4 && j == 3) centre_shift = (found - q).norm();
          ++points;
        }
      }
      EXPECT_GT(points, 20);
      EXPECT_LT(worst, 0.05) << "registration " << registration << " m, depth " << depth;
      ASSERT_GE(centre_shift, 0.0);
      EXPECT_NEAR(centre_shift, rectify::registration_parallax_px(f, 0.06, depth, registration),
                  0.05)
          << "registration " << registration << " m, depth " << depth;
      std::cout << "registration " << (registration > 0 ? std::to_string(registration) : "inf")
                << " m, point at " << depth << " m: parallax at the centre " << centre_shift
                << " px; table vs geometry " << worst << " px\n";
    }
  }
  EXPECT_NEAR(rectify::registration_parallax_px(f, 0.06, 10.0, 0.0), 5.0, 0.05);
}

// A raw image rendered through the Taylor model, remapped through the fixed-point table: a
// bright spot lands at the rectified position of its direction.
TEST(Rectification, RenderedSpotsLandAtTheirRectifiedPositions) {
  const auto& rig = paper_rig();
  const auto& pair = paper_maps().visible;
  const auto& g = pair.geometry;
  const auto& cam = rig.camera(rig.visible.left);
  const auto table = fpga::FixedPointMap::from_float(pair.left_map, cam.model->image_size());
  const fpga::FastRemapper remapper(table);
  const double sigma = 2.5 / g.grid.intrinsics().f;  // about 2.5 px
  double worst = 0.0;
  for (const auto& [alpha_deg, beta_deg] :
       {std::pair{0.0, 0.0}, std::pair{-45.0, 10.0}, std::pair{40.0, -20.0}, std::pair{52.0, 25.0},
        std::pair{-20.0, -30.0}}) {
    const double alpha = alpha_deg * M_PI / 180, beta = beta_deg * M_PI / 180;
    const Eigen::Vector3d dir(std::sin(alpha), std::cos(alpha) * std::sin(beta),
                              std::cos(alpha) * std::cos(beta));
    const cv::Mat raw = rectify::render_pattern(cam, g.T_ref_left_rect,
                                                rectify::angular_spot(dir, sigma), CV_8UC1, 1);
    const cv::Mat rectified = remapper.remap(raw);
    Eigen::Vector2d expected;
    ASSERT_TRUE(g.grid.project(dir, expected));
    // Intensity centroid in a window around the expected position.
    const cv::Rect window(static_cast<int>(expected.x()) - 12, static_cast<int>(expected.y()) - 12,
                          25, 25);
    double sum = 0, sx = 0, sy = 0;
    for (int v = window.y; v < window.y + window.height; ++v) {
      for (int u = window.x; u < window.x + window.width; ++u) {
        const double w = rectified.at<uchar>(v, u);
        sum += w;
        sx += w * u;
        sy += w * v;
      }
    }
    ASSERT_GT(sum, 1000.0) << "spot at " << alpha_deg << ", " << beta_deg << " deg not found";
    const double error = std::hypot(sx / sum - expected.x(), sy / sum - expected.y());
    worst = std::max(worst, error);
    EXPECT_LT(error, 0.15) << "spot at alpha " << alpha_deg << ", beta " << beta_deg << " deg";
  }
  std::cout << "largest spot position error " << worst << " px\n";
}

// The paper's elliptical model, fitted to the Taylor lenses: keeps the horizontal field.
TEST(EllipticalModel, FitsThePaperLensesAndKeepsTheField) {
  const auto& rig = paper_rig();
  for (const std::string name : {"visible.left", "infrared.left"}) {
    const auto& cam = rig.camera(name);
    const auto fit =
        rectify::fit_elliptical_model(dynamic_cast<const camera::TaylorCamera&>(*cam.model));
    const cv::Mat map = rectify::build_elliptical_map(fit.model);
    const double kept = rectify::field_kept_deg(*cam.model, map, map.rows / 2);
    EXPECT_GE(kept, 120.0) << name;
    EXPECT_GT(fit.model.k1, 0.0) << name;  // barrel correction
    // The edge midpoints map to the raw edge midpoints within a few px.
    const cv::Point2d edge = rectify::elliptical_source(
        fit.model, cam.model->image_size().width - 1, (cam.model->image_size().height - 1) / 2.0);
    EXPECT_NEAR(edge.x, cam.model->image_size().width - 1, 8.0) << name;
    std::cout << name << ": k1 " << fit.model.k1 << ", k2 " << fit.model.k2 << ", R " << fit.model.R
              << ", fit RMS " << fit.rms_px << " px, field kept " << kept << " deg\n";
  }
}

TEST(Rectification, CoincidentCamerasAreRefused) {
  const auto& rig = paper_rig();
  EXPECT_THROW(rectify::make_stereo_geometry(
                   rig, {rig.visible.left, rig.visible.left},
                   rectify::grid_matching_camera(rig.camera(rig.visible.left), 100)),
               std::invalid_argument);
  EXPECT_THROW(rectify::rectify_pair(rig, {"visible.left", "nope"},
                                     camera::RectifiedProjection::equirectangular),
               std::out_of_range);
}

}  // namespace
