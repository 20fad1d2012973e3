#pragma once
// The four stages in one process, one capture at a time: what `thermovis range`,
// `thermovis bench ranging` and `thermovis bench stages` run. The services run the same stage
// classes, one per process, on the same geometry; only the transport between them differs.
#include <array>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/camera/rig.hpp"
#include "thermovis/pipeline/detect_stage.hpp"
#include "thermovis/pipeline/match_stage.hpp"
#include "thermovis/pipeline/range_stage.hpp"
#include "thermovis/pipeline/rectify_fuse_stage.hpp"

namespace thermovis::pipeline {

struct CapturePipelineOptions {
  GridOptions grid;
  RectifyFuseOptions rectify;
  DetectOptions detect;
  // The band choice here is the default of range(); the other fields serve every choice.
  MatchStageOptions match;
  RangeStageOptions range;  // contour_reach_px follows match.match.patch_radius
  bool fuse = false;        // make the fused left image in rectify()
};

// Raw images as the cameras deliver them: visible CV_8UC3 (BGR) or CV_8UC1, infrared CV_16UC1
// counts or CV_8UC1, of the rig cameras' sizes.
struct RawCapture {
  cv::Mat visible_left, visible_right, infrared_left, infrared_right;
};

// One capture on the grid, as the services publish it.
struct GridCapture {
  cv::Mat visible_left,
      visible_right;  // the raw visible type (grey: RectifyFuseOptions::visible_mono)
  cv::Mat infrared_left, infrared_right;  // the raw infrared type (counts)
  cv::Mat fused_left;                     // with CapturePipelineOptions::fuse
  cv::Mat grey_left, grey_right;          // the visible pair as the matcher reads it
};

// A target ranged in one capture, with the matches each pair gave.
struct CaptureTarget {
  RangedTarget ranged;
  std::vector<BandMatches> matches;
  std::vector<RangedTarget> each_band;  // with each_band: every pair's own range, as matches
};

class CapturePipeline {
 public:
  // Computes the geometry and the maps. Throws std::invalid_argument for a rig without the
  // cameras its pairs name.
  CapturePipeline(const camera::Rig& rig, const CapturePipelineOptions& options = {});
  ~CapturePipeline();

  const PipelineGeometry& geometry() const { return rectify_.geometry(); }
  const CapturePipelineOptions& options() const { return options_; }

  // Throws std::invalid_argument naming a missing image or a wrong size or type.
  GridCapture rectify(const RawCapture& raw);
  std::vector<detect::Detection> detect(const GridCapture& capture) const;
  // One box (left image of the grid) of a target of class `label`, matched on the pairs of
  // `band` (visible, infrared, automatic, both: fused ranging) and ranged. The fused pair is
  // not made here (only its left eye): BandChoice::fused throws std::invalid_argument.
  CaptureTarget range(const GridCapture& capture, const cv::Rect& box, const std::string& label,
                      BandChoice band, bool each_band = false) const;

  // The stages themselves (benchmarks time them one by one).
  RectifyFuseStage& rectify_stage() { return rectify_; }
  const DetectStage& detect_stage() const { return detect_; }
  const MatchStage& match_stage(BandChoice band) const;
  const RangeStage& range_stage() const { return range_; }

 private:
  CapturePipelineOptions options_;
  RectifyFuseStage rectify_;
  DetectStage detect_;
  std::array<MatchStage, 5> match_;  // by BandChoice
  RangeStage range_;
};

}  // namespace thermovis::pipeline
