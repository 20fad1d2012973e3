#include "thermovis/pipeline/capture_pipeline.hpp"

#include <stdexcept>

namespace thermovis::pipeline {
namespace {

MatchStageOptions with_band(MatchStageOptions options, BandChoice band) {
  options.band = band;
  return options;
}

RangeStageOptions matched_with(RangeStageOptions options, const match::MatchOptions& match) {
  options.range.contour_reach_px = match.patch_radius;  // the patch that was correlated
  return options;
}

cv::Mat required(const cv::Mat& image, const char* what) {
  if (image.empty()) throw std::invalid_argument(std::string("no ") + what + " image");
  return image;
}

}  // namespace

CapturePipeline::CapturePipeline(const camera::Rig& rig, const CapturePipelineOptions& options)
    : options_(options),
      rectify_(rig, make_geometry(rig, options.grid), options.rectify),
      detect_(rectify_.geometry(), options.detect),
      match_{MatchStage(rectify_.geometry(), with_band(options.match, BandChoice::visible)),
             MatchStage(rectify_.geometry(), with_band(options.match, BandChoice::infrared)),
             MatchStage(rectify_.geometry(), with_band(options.match, BandChoice::fused)),
             MatchStage(rectify_.geometry(), with_band(options.match, BandChoice::automatic)),
             MatchStage(rectify_.geometry(), with_band(options.match, BandChoice::both))},
      range_(rectify_.geometry(), matched_with(options.range, options.match.match)) {}

CapturePipeline::~CapturePipeline() = default;

const MatchStage& CapturePipeline::match_stage(BandChoice band) const {
  return match_[static_cast<std::size_t>(band)];
}

GridCapture CapturePipeline::rectify(const RawCapture& raw) {
  GridCapture out;
  rectify_.rectify_visible(Eye::left, required(raw.visible_left, "visible left"), out.visible_left);
  rectify_.rectify_visible(Eye::right, required(raw.visible_right, "visible right"),
                           out.visible_right);
  rectify_.rectify_infrared(Eye::left, required(raw.infrared_left, "infrared left"),
                            out.infrared_left);
  rectify_.rectify_infrared(Eye::right, required(raw.infrared_right, "infrared right"),
                            out.infrared_right);
  out.grey_left = MatchStage::stage_grey(out.visible_left);
  out.grey_right = MatchStage::stage_grey(out.visible_right);
  if (options_.fuse) {
    rectify_.fuse(Eye::left, out.infrared_left,
                  rectify_.fusion_visible(Eye::left, out.visible_left, raw.visible_left),
                  out.fused_left);
  }
  return out;
}

std::vector<detect::Detection> CapturePipeline::detect(const GridCapture& capture) const {
  return detect_.detect(capture.infrared_left, capture.fused_left);
}

CaptureTarget CapturePipeline::range(const GridCapture& capture, const cv::Rect& box,
                                     const std::string& label, BandChoice band,
                                     bool each_band) const {
  if (band == BandChoice::fused) {
    throw std::invalid_argument("the fused pair is matched by the services only (--band fused)");
  }
  if (capture.infrared_left.type() != CV_16UC1) {
    // The matcher stretches infrared counts itself; 8-bit infrared (already gain-controlled)
    // is widened so that the same path serves it.
    GridCapture widened = capture;
    capture.infrared_left.convertTo(widened.infrared_left, CV_16U);
    capture.infrared_right.convertTo(widened.infrared_right, CV_16U);
    return range(widened, box, label, band, each_band);
  }
  MatchImages images{
      capture.grey_left, capture.grey_right, capture.infrared_left, capture.infrared_right, {}};
  CaptureTarget out;
  out.matches = match_stage(band).match(images, box, label);
  std::vector<TargetEntry> entries;
  for (const BandMatches& m : out.matches)
    entries.push_back({m.band, label, box, m.result.matches, m.result.region});
  if (entries.empty()) {
    out.ranged.range.message = "no pair to match on";
    return out;
  }
  out.ranged = range_.range(entries);
  if (each_band) {
    for (const TargetEntry& entry : entries) out.each_band.push_back(range_.range({entry}));
  }
  return out;
}

}  // namespace thermovis::pipeline
