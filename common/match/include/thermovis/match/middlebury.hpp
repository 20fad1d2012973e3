#pragma once
// Middlebury stereo scenes (MiddEval3 layout: im0.png, im1.png, calib.txt, disp0GT.pfm) and the
// accuracy of sparse matches against their ground-truth disparity.
//
// disp0GT.pfm holds disparities in pixels of the left image (im0), +inf where unknown. Its scale
// line only gives the byte order (the magnitude is ignored: OpenCV's PFM reader would multiply
// by 1/|scale|, hence the reader here). Rows are stored bottom-to-top in the file; read_pfm
// returns them top-to-bottom.
#include <filesystem>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/match/stereo_match.hpp"

namespace thermovis::match {

// One-channel PFM ("Pf") as CV_32FC1, top row first. Throws std::runtime_error naming the file
// and what is wrong (missing, not "Pf", truncated).
cv::Mat read_pfm(const std::filesystem::path& path);

struct MiddleburyScene {
  std::string name;
  cv::Mat left, right;   // 8-bit BGR
  cv::Mat ground_truth;  // CV_32FC1 disparity of the left image, px; +inf = unknown
  double ndisp = 0;      // disparity search bound from calib.txt, px
};

// Throws std::runtime_error naming the missing/unreadable file.
MiddleburyScene load_middlebury_scene(const std::filesystem::path& folder);

struct MatchAccuracy {
  int matches = 0;     // matches returned
  int with_truth = 0;  // of which the left pixel has a finite ground truth
  int within_1px = 0;  // |d - d_gt| <= 1
  int within_half_px = 0;
  double mean_abs_error_px = 0.0;  // over the matches within 1 px (sub-pixel accuracy)
  double fraction_1px() const { return with_truth ? double(within_1px) / with_truth : 0.0; }
  double fraction_half_px() const { return with_truth ? double(within_half_px) / with_truth : 0.0; }
};

// Errors at the nearest ground-truth pixel of each match's left point.
MatchAccuracy evaluate_matches(const std::vector<Correspondence>& matches,
                               const cv::Mat& ground_truth);

}  // namespace thermovis::match
