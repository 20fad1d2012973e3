#include "thermovis/pipeline/range_stage.hpp"

#include <cmath>
#include <stdexcept>

#include "thermovis/util/enum_names.hpp"

namespace thermovis::pipeline {

namespace {

constexpr util::EnumName<RangeEstimate> kRangeEstimateNames[] = {{RangeEstimate::points, "points"},
                                                                 {RangeEstimate::region, "region"},
                                                                 {RangeEstimate::both, "both"}};

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
      T_reporting_ref_(geometry.T_ref_reporting.inverse()),
      options_(options) {}

range::TargetRange RangeStage::range_entry(const TargetEntry& entry, double& shared_sigma_m) const {
  const range::RangingGeometry& geometry = entry.band == Band::infrared ? infrared_ : visible_;
  range::RangeOptions options = options_.range;
  options.region_systematic_disparity_px =
      1e-3 * grid_px_per_rad_ *
      (entry.band == Band::infrared ? options_.region_floor_infrared_mrad
                                    : options_.region_floor_visible_mrad);
  if (entry.band == Band::infrared)
    options.systematic_disparity_px = 1e-3 * grid_px_per_rad_ * options_.points_floor_infrared_mrad;
  if (!options_.surface) options.shape = range::TargetShape::for_class(entry.label);
  shared_sigma_m = options.shape.empty() ? 0.0 : options.shape_sigma_m;
  const double to_centre = options_.surface ? 0.0 : range::surface_to_centre_m(entry.label);
  if (options_.estimate == RangeEstimate::region)
    return range::range_region(geometry, entry.box, entry.region, to_centre, options);
  range::TargetRange region;
  if (options_.estimate == RangeEstimate::both) {
    region = range::range_region(geometry, entry.box, entry.region, to_centre, options);
    // The whole region is where the target's points are: a group elsewhere is a mismatch.
    if (region.status == range::RangeStatus::ok) options.group_hint_m = region.distance_m;
  }
  range::TargetRange points = range::range_target(geometry, entry.box, entry.points, options);
  if (!options_.surface && options.shape.empty())
    range::move_to_centre(points, geometry, to_centre);
  if (options_.estimate == RangeEstimate::points) return points;
  // The points and the region see the same pixels: their shared error is at least the
  // systematic floor and the shape's, kept whole by the combination.
  double shared_in_pair = shared_sigma_m;
  if (region.status == range::RangeStatus::ok && region.disparity_sigma_px > 0) {
    const double per_px = region.sigma_m / region.disparity_sigma_px;
    const double floor_m =
        std::min(options.systematic_disparity_px, options.region_systematic_disparity_px) * per_px;
    shared_in_pair = std::sqrt(shared_in_pair * shared_in_pair + floor_m * floor_m);
  }
  return range::combine_ranges(points, region, geometry, shared_in_pair);
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
  double shared_sigma = 0.0;
  out.range = range_entry(entries[0], shared_sigma);
  out.band = entries[0].band;
  if (entries.size() == 2) {
    // Two pairs' independent measurements (the shape's error is one error in both), or the one
    // pair that gave a range.
    range::CombinedFrom from = range::CombinedFrom::neither;
    out.range = range::combine_ranges(out.range, range_entry(entries[1], shared_sigma), visible_,
                                      shared_sigma, &from);
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
