#include "thermovis/pipeline/range_stage.hpp"

#include <cmath>
#include <stdexcept>

namespace thermovis::pipeline {

RangeStage::RangeStage(const PipelineGeometry& geometry, const RangeStageOptions& options)
    : visible_(geometry.ranging(Band::visible)),
      infrared_(geometry.ranging(Band::infrared)),
      T_reporting_ref_(geometry.T_ref_reporting.inverse()),
      options_(options) {}

range::TargetRange RangeStage::range_entry(const TargetEntry& entry, double& shared_sigma_m) const {
  const range::RangingGeometry& geometry = entry.band == Band::infrared ? infrared_ : visible_;
  range::RangeOptions options = options_.range;
  if (!options_.surface) options.shape = range::TargetShape::for_class(entry.label);
  shared_sigma_m = options.shape.empty() ? 0.0 : options.shape_sigma_m;
  range::TargetRange r = range::range_target(geometry, entry.box, entry.points, options);
  if (!options_.surface && options.shape.empty()) {
    range::move_to_centre(r, geometry, range::surface_to_centre_m(entry.label));
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
