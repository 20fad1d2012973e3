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
#include <utility>
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
  // The whole-target alignment of every box on every pair (match::align_region), in
  // MatchResult::region: the target's silhouette in the infrared image of the grid (the warm
  // body, match::target_silhouette) as its mask on both pairs (on the visible pair displaced by
  // the two cameras' parallax at the target's distance), the whole box where there is no
  // infrared image or the box does not split; started from the points' median disparity when
  // there are at least 3, else searched over the disparities the class's size allows.
  bool region = true;
  // Boxes with this many point correspondences or more are not aligned as a whole: their
  // points alone range them as well (near people, hundreds of pixels high), and the region's
  // one translation fits a near target's depth less well; it also keeps the stage's CPU in the
  // real-time budget.
  int region_below_points = 12;
  // Boxes with fewer points than this are also aligned when their points hold a nearer group
  // than their median's: at least 3 of them more than a window above the median disparity (the
  // range's group window, range::RangeOptions' defaults: 6 % of it, at least 0.5 px). The range's
  // screen keeps the nearest dense group, right when the target is in front of a background seen in
  // its box, wrong when a few points matched one period off on a repeated texture (a striped
  // shirt): the region's range chooses between the groups (RangeStage). Points whose other group is
  // farther (the background behind a target that holds most of them) are left to the screen, and
  // near targets, with hundreds of points, keep their points alone.
  int region_split_below_points = 36;
  match::RegionOptions region_options;  // its disparity range is set like the points'
};

// One capture's pairs, as the stage reads them. primary: the visible or fused pair on the grid,
// CV_8UC1 grey (stage_grey makes it from BGR); infrared: CV_16UC1 counts on the infrared pair's
// grid (PipelineGeometry::image_size; its points and disparities come back in grid pixels). A pair
// the choice does not use, or that is not there, is left empty.
struct MatchImages {
  cv::Mat primary_left, primary_right;
  cv::Mat infrared_left, infrared_right;
  // The left infrared image the targets' silhouettes come from, where the infrared pair is not
  // to be matched here (matched apart: MatchNode with band both); else infrared_left is used.
  cv::Mat silhouette_infrared;
};

struct BandMatches {
  Band band = Band::visible;
  match::MatchResult result;
};

// The range of heights of an upright target of a class, m, that bounds its distance from its
// box's height (person 1.0-2.1 m: a child to a tall adult, standing); {0, 0} for classes without
// one.
std::pair<double, double> typical_height_m(const std::string& label);

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
  // `label` (the detection's class) bounds a region's disparity search by the class's size
  // where no points start it (typical_height_m).
  std::vector<BandMatches> match(const MatchImages& images, const cv::Rect& box,
                                 const std::string& label = "") const;
  // match() of every box of a capture, in the boxes' order: with cv::getNumThreads() > 1 (a
  // service's --threads) the boxes are shared among OpenCV's worker threads, the results
  // unchanged. The first box's error (in the boxes' order) is rethrown after all have run.
  struct Box {
    cv::Rect box;
    std::string label;
  };
  std::vector<std::vector<BandMatches>> match_each(const MatchImages& images,
                                                   const std::vector<Box>& boxes) const;
  // One pair: `left`/`right` grey for visible and fused, counts for infrared.
  // `infrared_left`: the grid's left infrared image (counts), where the region's silhouette is
  // found (empty: the region is the whole box). `height_m`: the class's height range
  // (typical_height_m), {0, 0} for none.
  match::MatchResult match_on(Band band, const cv::Mat& left, const cv::Mat& right,
                              const cv::Rect& box, const cv::Mat& infrared_left = cv::Mat(),
                              std::pair<double, double> height_m = {0, 0}) const;

  // Whether a box with these points gets a whole-region alignment (region_below_points,
  // region_split_below_points).
  bool aligns(const match::MatchResult& result) const;

 private:
  // The whole-region alignment of `box` into result.region (with MatchStageOptions::region).
  void align(Band band, const cv::Mat& left8, const cv::Mat& right8, const cv::Rect& box,
             const cv::Mat& silhouette, std::pair<double, double> height_m,
             match::MatchResult& result) const;

  cv::Size grid_size_;
  cv::Size infrared_size_;      // the infrared pair's images (PipelineGeometry::image_size)
  int infrared_reduction_ = 1;  // grid px per infrared image px
  // The infrared pair's search in its own image's pixels.
  match::MatchOptions infrared_match_;
  match::RegionOptions infrared_region_;
  double baseline_visible_m_ = 0, baseline_infrared_m_ = 0;
  double infrared_rows_per_disparity_ = 0;  // the infrared pair's epipolar slope on the grid
  // Where the infrared silhouette lies on the visible image: shift (px) = per_disparity *
  // visible disparity + constant (registration at a finite distance).
  Eigen::Vector2d silhouette_shift_per_disparity_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d silhouette_shift_ = Eigen::Vector2d::Zero();
  MatchStageOptions options_;
};

}  // namespace thermovis::pipeline
