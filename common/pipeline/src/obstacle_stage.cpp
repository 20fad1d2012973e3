#include "thermovis/pipeline/obstacle_stage.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace thermovis::pipeline {
namespace {

namespace ob = obstacle;

std::vector<ob::PairSetup> pair_setups(const PipelineGeometry& geometry,
                                       const ObstacleStageOptions& options) {
  if (!options.visible && !options.infrared) {
    throw std::invalid_argument("the obstacle stage needs the visible or the infrared pair");
  }
  std::vector<ob::PairSetup> pairs;
  if (options.visible) pairs.push_back({ob::PairBand::visible, geometry.ranging(Band::visible)});
  if (options.infrared) {
    pairs.push_back(
        {ob::PairBand::infrared, geometry.ranging(Band::infrared), geometry.infrared_reduction});
  }
  return pairs;
}

// The options with the reduction chosen for the grid (ObstacleStageOptions::reduced_px_per_rad).
ObstacleStageOptions for_grid(const PipelineGeometry& geometry, ObstacleStageOptions options) {
  int reduction = grid_reduction(geometry.grid, options.reduced_px_per_rad);
  // A multiple of the infrared images' own reduction, which must divide it.
  const int k = geometry.infrared_reduction;
  if (options.infrared && k > 1) reduction = std::max(k, (reduction + k / 2) / k * k);
  if (options.reduced_px_per_rad > 0) options.obstacles.reduction = reduction;
  return options;
}

unsigned band_bits(Band band) {
  switch (band) {
    case Band::visible:
      return ob::kVisibleBit;
    case Band::infrared:
      return ob::kInfraredBit;
    case Band::fused:
      break;
  }
  return ob::kVisibleBit | ob::kInfraredBit;
}

// Distance of a point along the ground (its offset along the plane's normal left out), m.
double horizontal_distance(const Eigen::Vector3d& p, const ob::GroundPlane& ground) {
  return (p - ground.normal.dot(p) * ground.normal).norm();
}

}  // namespace

ObstacleStage::ObstacleStage(const PipelineGeometry& geometry, const ObstacleStageOptions& options)
    : geometry_(geometry),
      options_(for_grid(geometry, options)),
      detector_(geometry.grid, pair_setups(geometry, options_), geometry.T_ref_reporting,
                options_.mounting, options_.obstacles),
      prior_reporting_(
          ob::plane_in_frame(ob::prior_plane(options.mounting), geometry.T_ref_reporting)) {
  R_reporting_rect_ =
      (geometry.T_ref_reporting.inverse() * geometry.visible.T_ref_left_rect).rotation();
  if (!(options_.merge_overlap > 0 && options_.merge_overlap <= 1)) {
    throw std::invalid_argument("merge_overlap must be in (0, 1]");
  }
  if (!(options_.merge_tolerance_m >= 0) || !(options_.merge_tolerance_share >= 0)) {
    throw std::invalid_argument("merge tolerances must be >= 0");
  }
}

ObstacleReport ObstacleStage::report(const ob::ObstacleResult& result,
                                     const std::vector<RangedTarget3d>& targets) const {
  ObstacleReport out;
  out.ground_reporting = prior_reporting_;
  for (const ob::PairObstacles& p : result.pairs) {
    if (p.ok()) {
      out.ground_reporting = p.ground_reporting;
      break;
    }
  }
  const int width = geometry_.grid.width;
  out.free_space_m = result.free_space_m;
  out.free_space_m.resize(static_cast<std::size_t>(width), std::numeric_limits<float>::quiet_NaN());

  const double f = geometry_.grid.f;
  std::vector<bool> merged(result.obstacles.size(), false);
  for (const RangedTarget3d& t : targets) {
    if (!t.position_m.allFinite() || !std::isfinite(t.sigma_m) || t.sigma_m < 0) {
      throw std::invalid_argument("target " + std::to_string(t.target_id) +
                                  ": a non-finite position or a sigma that is not >= 0");
    }
    ReportedObstacle r;
    r.label = t.label;
    r.target_id = t.target_id;
    ob::Obstacle& o = r.obstacle;
    o.box = t.box;
    o.distance_m = horizontal_distance(t.position_m, out.ground_reporting);
    o.sigma_m = t.sigma_m;
    o.position_m = t.position_m;
    o.bands = band_bits(t.band);
    // Without stixels: its box's angles at its distance (rows are angles; columns too on the
    // equirectangular grid, about so on the cylindrical one near its centre).
    o.extent_m = {t.box.width / f * o.distance_m, t.box.height / f * o.distance_m, 0.0};
    bool measured_extent = false;
    for (std::size_t k = 0; k < result.obstacles.size(); ++k) {
      const ob::Obstacle& s = result.obstacles[k];
      if (merged[k]) continue;
      const double inside = (s.box & t.box).area();
      if (inside < options_.merge_overlap * s.box.area()) continue;
      if (std::abs(s.distance_m - o.distance_m) >
          options_.merge_tolerance_m + options_.merge_tolerance_share * o.distance_m) {
        continue;
      }
      merged[k] = true;
      o.bands |= s.bands;
      o.stixels += s.stixels;
      o.extent_m = measured_extent ? o.extent_m.cwiseMax(s.extent_m) : s.extent_m;
      measured_extent = true;
    }
    // Nothing in its columns is farther than the target.
    const int x0 = std::max(0, t.box.x), x1 = std::min(width, t.box.x + t.box.width);
    for (int x = x0; x < x1; ++x) {
      float& fs = out.free_space_m[static_cast<std::size_t>(x)];
      const auto d = static_cast<float>(o.distance_m);
      fs = std::isnan(fs) ? d : std::min(fs, d);
    }
    out.obstacles.push_back(std::move(r));
  }
  for (std::size_t k = 0; k < result.obstacles.size(); ++k) {
    if (merged[k]) continue;
    ReportedObstacle r;
    r.obstacle = result.obstacles[k];
    out.obstacles.push_back(std::move(r));
  }
  std::stable_sort(out.obstacles.begin(), out.obstacles.end(), [](const auto& a, const auto& b) {
    return a.obstacle.distance_m < b.obstacle.distance_m;
  });

  // The free space's row per column. A grid pixel's ray in the rectified frame is
  // (sin a, cos a sin b, cos a cos b) (a from the column, b = (v - cy) / f); a ground point at
  // horizontal distance d is seen along a ray whose component along the ground's normal n is
  // s = h / sqrt(d^2 + h^2). With the normal in the rectified frame m = R^T n that is
  // m_x sin a + cos a (m_y sin b + m_z cos b) = s, solved for b.
  const Eigen::Vector3d m = R_reporting_rect_.transpose() * out.ground_reporting.normal;
  const double h = out.ground_reporting.height_m;
  const auto& g = geometry_.grid;
  out.free_space_row.assign(out.free_space_m.size(), std::numeric_limits<float>::quiet_NaN());
  for (std::size_t u = 0; u < out.free_space_m.size(); ++u) {
    const double d = out.free_space_m[u];
    if (!std::isfinite(d) || !(d > 0) || !(h > 0)) continue;
    const double x = (static_cast<double>(u) - g.cx) / g.f;
    const double a = g.projection == camera::RectifiedProjection::cylindrical ? std::atan(x) : x;
    const double target = h / std::hypot(d, h) - m.x() * std::sin(a);
    const double b_coef = std::cos(a) * m.y(), c_coef = std::cos(a) * m.z();
    const double r = std::hypot(b_coef, c_coef);
    if (!(r > 0) || std::abs(target) > r) continue;
    // r sin(b + phi) = target with phi = atan2(c, b): the branch below the horizon.
    const double beta = std::asin(target / r) - std::atan2(c_coef, b_coef);
    const double row = g.cy + g.f * beta;
    if (row >= -0.5 && row <= g.height - 0.5) out.free_space_row[u] = static_cast<float>(row);
  }
  return out;
}

}  // namespace thermovis::pipeline
