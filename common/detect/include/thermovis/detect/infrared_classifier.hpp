#pragma once
// Infrared people by candidates and a classifier (trained here, from our own annotated frames):
//  1. the frame becomes 8-bit (CV_8UC1 as it is; CV_16UC1 raw counts stretched linearly from
//     the 1st to the 99.9th percentile of the field's pixels onto 1..255; 0 stays outside);
//  2. candidates: warm regions at several thresholds, nested (a level's components are searched
//     for warmer components inside their boxes), so that people touching one another or
//     standing on warm ground still come out as components of their own at some level; a
//     component too wide or too tall for one person also gives person-shaped windows across
//     it, fitted to its pixels (people touching at the same warmth never part at a threshold);
//  3. each candidate is described by HOG on its box with a margin (resized to a fixed window,
//     so the description does not depend on the person's size in pixels) and by scale-free
//     shape and contrast features (aspect, fill, contrast to the ring around the box, to the
//     threshold and to the enclosing component);
//  4. boosted trees (OpenCV ml, Real AdaBoost) score them: a person model (people against the
//     background) plus a fit model (a box that fits a person against the part of a person or
//     the group of people that a candidate around them also is: a torso's box, two people in
//     one box), so that of the candidates about one person the one that fits ranks first;
//     boxes above min_score are kept and non-maximum suppression keeps the best of overlapping
//     ones.
#include <filesystem>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <opencv2/objdetect.hpp>
#include <vector>

#include "thermovis/detect/detectors.hpp"

namespace thermovis::detect {

struct CandidateOptions {
  int levels = 8;                // thresholds per frame
  double first_k_sigma = 2.0;    // lowest: field median + this many robust sigmas (1.4826 MAD)
  double top_percentile = 99.9;  // highest threshold stays below this percentile of the field
  int min_height_px = 4;
  int min_area_px = 6;
  double max_frame_fraction = 0.25;  // larger components (the warm ground itself) are no person
  // Each component gives a box per growth: its own (0) and ones grown by that fraction of its
  // size on each side; the classifier picks the one that fits the person.
  std::vector<double> box_growth = {0.0, 0.1, 0.25};
  // People touching side by side or one behind the other (seen from above) form one component
  // at every threshold. A component wider than split_wide x its height gives person-shaped
  // windows across it (widths split_widths x its height), one taller than split_tall x its
  // width gives windows down it (heights split_heights x its width); each window's other extent
  // is fitted to the component's pixels inside it. Components under split_min_px are not split.
  double split_wide = 0.6;
  std::vector<double> split_widths = {0.35, 0.5};
  double split_tall = 3.5;
  std::vector<double> split_heights = {2.5, 3.2};
  int split_min_px = 16;
  double split_min_fill = 0.25;  // a window needs this share of its pixels in the component
};

struct Candidate {
  cv::Rect box;
  int level = 0;              // 0 = lowest threshold
  double area_px = 0;         // pixels of the component
  double threshold = 0;       // grey level of its threshold (8-bit)
  double parent_area_px = 0;  // of the enclosing component one level down (own area at level 0)
  double growth = 0;          // the box is the component's grown by this on each side
  bool split = false;         // a window inside a component (box fitted), not its own box
};

// The 8-bit image candidates and features are computed on (see 1. above). Throws
// std::invalid_argument for a type other than CV_8UC1 or CV_16UC1.
cv::Mat infrared_to_8bit(const cv::Mat& infrared);

std::vector<Candidate> infrared_candidates(const cv::Mat& ir8,
                                           const CandidateOptions& options = {});

// One CV_32F row of features per candidate (same order).
cv::Mat candidate_features(const cv::Mat& ir8, const std::vector<Candidate>& candidates);

// The HOG of candidate_features' windows (each candidate's box with its margin, shrunk to 20 x
// 20 px).
cv::HOGDescriptor classifier_hog();

// The HOG descriptors of many 8-bit windows of one size in one cv::HOGDescriptor::compute call:
// the windows are laid side by side in a mosaic, each in a 1-px BORDER_REFLECT_101 frame. The
// frame gives each window's edge pixels the gradients compute() gives a window alone (it
// reflects the same way beyond an image's edge), so the descriptors are bit-identical to one
// call per window, without that call's per-image set-up (bench_detect's BM_CandidateHogs: about
// 1.7-1.9x faster on a pipeline frame's 402 windows; keep a mosaic to about a hundred windows,
// whose gradients stay in the core's cache).
class HogMosaic {
 public:
  // `windows` windows of hog.winSize. Keeps a reference to `hog`, which must outlive it.
  HogMosaic(const cv::HOGDescriptor& hog, int windows);
  // The window to write window i into (CV_8UC1, hog.winSize; a scratch image, framed by set).
  cv::Mat& scratch() { return scratch_; }
  // Frames scratch() as window i. Throws std::out_of_range for an index outside 0..windows-1 and
  // std::invalid_argument when scratch() is not a CV_8UC1 image of the window size.
  void set(int i);
  // windows x descriptor size floats, window after window.
  std::vector<float> compute() const;

 private:
  const cv::HOGDescriptor& hog_;
  int windows_ = 0;
  cv::Size tile_;
  int columns_ = 1;  // windows per row of the mosaic
  cv::Mat mosaic_;
  cv::Mat scratch_;
  std::vector<cv::Point> locations_;
};

// The trained scorer. The model file (.yml or .yml.gz) holds two OpenCV ml::Boost models in
// FileStorage form, nodes "person" and "fit".
class InfraredClassifier {
 public:
  // Throws std::runtime_error naming the file when it cannot be read or holds no trained model
  // of the feature size candidate_features gives.
  explicit InfraredClassifier(const std::filesystem::path& model);
  ~InfraredClassifier();
  InfraredClassifier(InfraredClassifier&&) noexcept;
  InfraredClassifier& operator=(InfraredClassifier&&) noexcept;

  // Sum of both models' weak trees' votes per row of candidate_features (> 0: person).
  std::vector<double> score(const cv::Mat& features) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct TrainingSample {
  cv::Mat features;       // one row
  int label = 0;          // 1 person (person_iou >= positive_iou), 0 not
  double person_iou = 0;  // the candidate's largest IoU with a person box
};

struct TrainingOptions {
  double positive_iou = 0.5;  // a candidate this close to a person box is one
  double negative_iou = 0.3;  // one that overlaps no person (or don't-care box) this much is not
  // Negatives of one frame beyond this are thinned evenly (the warm ground of one frame gives
  // thousands of near-identical ones); 0 = keep all.
  int max_negatives_per_frame = 0;
  int weak_count = 150;
  int max_depth = 2;
  // The fit model: people against candidates that overlap one (IoU at least fit_min_iou) but
  // are not one (parts, groups; those between the two IoUs above included).
  double fit_min_iou = 0.1;
  int fit_weak_count = 100;
};

// The labelled candidates of one annotated frame (those at a don't-care box are left out).
// Appends to samples; returns how many person boxes have a candidate >= positive_iou (the
// recall the classifier can reach at best).
int collect_training_samples(const cv::Mat& infrared, const std::vector<cv::Rect>& persons,
                             const std::vector<cv::Rect>& dont_care,
                             const CandidateOptions& candidate_options,
                             const TrainingOptions& options, std::vector<TrainingSample>& samples);

// Trains both models and writes them to model. Throws std::invalid_argument when there are no
// samples of one class of a model.
void train_infrared_classifier(const std::vector<TrainingSample>& samples,
                               const TrainingOptions& options, const std::filesystem::path& model);

}  // namespace thermovis::detect
