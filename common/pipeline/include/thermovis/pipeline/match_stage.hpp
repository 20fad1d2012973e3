#pragma once
// Stage 3: stereo correspondences inside each target box (match/stereo_match.hpp: along the
// box's epipolar rows of the right image, sub-pixel), on the pair or pairs the band choice names.
//
// Bands (BandChoice):
//  - visible: the rectified visible pair (grey);
//  - infrared: the rectified infrared pair: raw counts, the box's search region (the same in
//    both eyes, so disparities are kept) stretched linearly to 8 bits between the left region's
//    0.5 and 99.5 percentiles; its disparities follow the infrared baseline;
//  - both (the default): every box on both pairs; the range stage combines the two pairs' ranges
//    by their uncertainties;
//  - automatic: visible first, and the infrared pair for a box where the visible one gives fewer
//    than `min_visible_points` correspondences (night, glare, a featureless box);
//  - fused: the fused pair. The infrared content of a fused image is registered at one distance,
//    so its disparities mix the two baselines (0.336 and 0.358 m for the paper rig): ranges are
//    biased by up to their difference (6 %); kept for comparison.
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/match/stereo_match.hpp"
#include "thermovis/pipeline/geometry.hpp"

namespace thermovis::pipeline {

enum class BandChoice { visible, infrared, fused, automatic, both };
// "visible" | "infrared" | "fused" | "auto" | "both"; std::invalid_argument otherwise.
BandChoice parse_band_choice(const std::string& name);

struct MatchStageOptions {
  BandChoice band = BandChoice::both;
  int min_visible_points = 8;  // automatic: fewer visible correspondences -> the infrared pair
  // Method, patch and thresholds; the disparity range is set from the geometry and
  // min_distance_m.
  match::MatchOptions match;
  double min_distance_m = 2.5;  // nearest target searched (sets the largest disparity)
};

// One capture's pairs on the grid, as the stage reads them. primary: the visible or fused pair,
// CV_8UC1 grey (stage_grey makes it from BGR); infrared: CV_16UC1 counts. A pair the choice does
// not use, or that is not there, is left empty.
struct MatchImages {
  cv::Mat primary_left, primary_right;
  cv::Mat infrared_left, infrared_right;
};

struct BandMatches {
  Band band = Band::visible;
  match::MatchResult result;
};

class MatchStage {
 public:
  MatchStage(const PipelineGeometry& geometry, const MatchStageOptions& options = {});
  // The pair read besides the infrared: visible or fused (infrared for the infrared choice).
  Band primary_band() const;
  bool uses_primary() const { return options_.band != BandChoice::infrared; }
  bool uses_infrared() const;
  const match::MatchOptions& match_options() const { return options_.match; }

  // A received image as the stage wants it: BGR to grey, grey and 16-bit counts copied.
  // Throws std::invalid_argument for another type.
  static cv::Mat stage_grey(const cv::Mat& image);

  // The matches of one box (left image of the grid) on every pair the choice asks for that is
  // present: one entry, or two (the primary pair's first) for `both`. Throws
  // std::invalid_argument for images of the wrong size or type.
  std::vector<BandMatches> match(const MatchImages& images, const cv::Rect& box) const;
  // One pair: `left`/`right` grey for visible and fused, counts for infrared.
  match::MatchResult match_on(Band band, const cv::Mat& left, const cv::Mat& right,
                              const cv::Rect& box) const;

 private:
  cv::Size grid_size_;
  MatchStageOptions options_;
};

}  // namespace thermovis::pipeline
