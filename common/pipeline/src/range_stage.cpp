#include "thermovis/pipeline/range_stage.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::pipeline {

namespace {

constexpr util::EnumName<RangeEstimate> kRangeEstimateNames[] = {{RangeEstimate::points, "points"},
                                                                 {RangeEstimate::region, "region"},
                                                                 {RangeEstimate::both, "both"}};

// Whether two ranges of one target lie further apart than 3 sigma of their difference (their own
// errors: the shared part is one error in both).
bool disagree(const range::TargetRange& a, const range::TargetRange& b, double shared_sigma_m) {
  const double apart = (a.position_m - b.position_m).norm();
  const double spread = std::sqrt(std::max(
      a.sigma_m * a.sigma_m + b.sigma_m * b.sigma_m - 2 * shared_sigma_m * shared_sigma_m, 1e-12));
  return apart > 3.0 * spread;
}

bool usable(const range::TargetRange& r) {
  return r.status == range::RangeStatus::ok && std::isfinite(r.sigma_m) && r.sigma_m > 0;
}

}  // namespace

RangeEstimate parse_range_estimate(const std::string& name) {
  if (const auto estimate = util::parse(kRangeEstimateNames, name)) return *estimate;
  throw std::invalid_argument("unknown range estimate '" + name + "' (" +
                              util::join_names(kRangeEstimateNames, ", ", ", ") + ")");
}

RangeStage::RangeStage(const PipelineGeometry& geometry, const RangeStageOptions& options)
    : visible_(geometry.ranging(Band::visible)),
      infrared_(geometry.ranging(Band::infrared)),
      grid_px_per_rad_(geometry.grid.f),
      infrared_reduction_(geometry.infrared_reduction),
      T_reporting_ref_(geometry.T_ref_reporting.inverse()),
      options_(options) {}

const range::RangingGeometry& RangeStage::geometry_of(const TargetEntry& entry) const {
  return entry.band == Band::infrared ? infrared_ : visible_;
}

range::TargetRange RangeStage::range_entry(const TargetEntry& entry, double& shared_sigma_m,
                                           double hint_m) const {
  const range::RangingGeometry& geometry = geometry_of(entry);
  range::RangeOptions options = options_.range;
  options.region_systematic_disparity_px =
      1e-3 * grid_px_per_rad_ *
      (entry.band == Band::infrared ? options_.region_floor_infrared_mrad
                                    : options_.region_floor_visible_mrad);
  options.systematic_disparity_px =
      1e-3 * grid_px_per_rad_ *
      (entry.band == Band::infrared ? options_.points_floor_infrared_mrad
                                    : options_.points_floor_visible_mrad);
  // The infrared patches were correlated on the reduced image: their reach in grid px.
  if (entry.band == Band::infrared) options.contour_reach_px *= infrared_reduction_;
  if (!options_.surface) options.shape = range::TargetShape::for_class(entry.label);
  shared_sigma_m = options.shape.empty() ? 0.0 : options.shape_sigma_m;
  const double to_centre = options_.surface ? 0.0 : range::surface_to_centre_m(entry.label);
  if (options_.estimate == RangeEstimate::region)
    return range::range_region(geometry, entry.box, entry.region, to_centre, options);
  range::TargetRange region;
  // The region's metres per pixel of disparity (0: no region).
  double region_per_px = 0.0;
  if (options_.estimate == RangeEstimate::both) {
    region = range::range_region(geometry, entry.box, entry.region, to_centre, options);
    if (region.status == range::RangeStatus::ok && region.disparity_sigma_px > 0)
      region_per_px = region.sigma_m / region.disparity_sigma_px;
    // The whole region is where the target's points are: a group elsewhere is a mismatch.
    if (region.status == range::RangeStatus::ok) options.group_hint_m = region.distance_m;
    if (std::isfinite(hint_m)) {
      options.group_hint_m = hint_m;
      if (region.status == range::RangeStatus::ok &&
          std::abs(region.distance_m - hint_m) >
              2.0 * range::group_window_m(options, hint_m, region_per_px)) {
        region.status = range::RangeStatus::no_region;
        region.message = "the region's range is not near the other pair's";
      }
    }
  }
  range::TargetRange points = range::range_target(geometry, entry.box, entry.points, options);
  if (!options_.surface && options.shape.empty())
    range::move_to_centre(points, geometry, to_centre);
  if (options_.estimate == RangeEstimate::points) return points;
  // The points and the region see the same pixels: their shared error is at least the
  // systematic floor and the shape's, kept whole by the combination.
  double shared_in_pair = shared_sigma_m;
  if (region.status == range::RangeStatus::ok && region_per_px > 0) {
    const double floor_m =
        std::min(options.systematic_disparity_px, options.region_systematic_disparity_px) *
        region_per_px;
    shared_in_pair = std::sqrt(shared_in_pair * shared_in_pair + floor_m * floor_m);
  }
  // Points grouped about the region's range that still range elsewhere: the region aligned
  // partly off the target (its silhouette's mask on the background beside it), the points'
  // own correspondences did not.
  if (usable(points) && usable(region) && disagree(points, region, shared_in_pair)) return points;
  range::TargetRange combined = range::combine_ranges(points, region, geometry, shared_in_pair);
  combined.used = points.used;  // one pair's points: their indices still mean its matches
  return combined;
}

range::TargetRange RangeStage::combine_pairs(const std::vector<TargetEntry>& entries,
                                             range::CombinedFrom& from) const {
  // Two pairs' independent measurements (the shape's error is one error in both), or the one
  // pair that gave a range.
  double shared = 0.0;
  range::TargetRange a = range_entry(entries[0], shared);
  range::TargetRange b = range_entry(entries[1], shared);
  const auto combined = [&] { return range::combine_ranges(a, b, visible_, shared, &from); };
  if (!usable(a) || !usable(b) || !disagree(a, b, shared)) return combined();
  const double apart = (a.position_m - b.position_m).norm();
  // Each pair grouped about the other's range (seen from its own left camera): a pair whose
  // points also hold a group at the other's distance erred with the rest of them.
  const auto seen_from = [&](const TargetEntry& entry, const range::TargetRange& r) {
    return (geometry_of(entry).T_ref_left_rect.inverse() * r.position_m).norm();
  };
  double unused = 0.0;
  const range::TargetRange a_at_b = range_entry(entries[0], unused, seen_from(entries[0], b));
  const range::TargetRange b_at_a = range_entry(entries[1], unused, seen_from(entries[1], a));
  const bool a_agrees = usable(a_at_b), b_agrees = usable(b_at_a);
  if (a_agrees &&
      (!b_agrees || a_at_b.points_used + b.points_used >= a.points_used + b_at_a.points_used)) {
    a = a_at_b;
  } else if (b_agrees) {
    b = b_at_a;
  }
  range::TargetRange r = combined();
  if (!a_agrees && !b_agrees) {
    // Neither pair's points support the other's range: the combination's uncertainty covers
    // both rather than claiming the precision of either.
    const double widened = std::sqrt(r.sigma_m * r.sigma_m + 0.25 * apart * apart);
    r.disparity_sigma_px *= widened / r.sigma_m;
    r.sigma_m = widened;
  }
  return r;
}

RangedTarget RangeStage::range(const std::vector<TargetEntry>& entries) const {
  if (entries.empty() || entries.size() > 2) {
    throw std::invalid_argument("range: a target has one or two entries, not " +
                                std::to_string(entries.size()));
  }
  if (entries.size() == 2 &&
      (entries[0].band == Band::infrared) == (entries[1].band == Band::infrared)) {
    throw std::invalid_argument("range: a target's two entries are of one pair");
  }
  RangedTarget out;
  out.band = entries[0].band;
  if (entries.size() == 1) {
    double shared_sigma = 0.0;
    out.range = range_entry(entries[0], shared_sigma);
  } else {
    range::CombinedFrom from = range::CombinedFrom::neither;
    out.range = combine_pairs(entries, from);
    if (from == range::CombinedFrom::both) out.band = Band::fused;
    if (from == range::CombinedFrom::b) out.band = entries[1].band;
  }
  if (out.range.status == range::RangeStatus::ok) {
    out.position_m = T_reporting_ref_ * out.range.position_m;
    out.distance_m = out.position_m.norm();
  }
  return out;
}

}  // namespace thermovis::pipeline
