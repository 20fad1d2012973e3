#pragma once
// Person detection measured on annotated frames.
//
// A folder of annotated frames holds infrared/<name>.<ext>, optionally visible/<name>.<ext>
// (registered with the infrared image: one box serves both) and boxes.json:
//   {"<name>": [{"label": "person", "box": [x0, y0, x1, y1]}, ...], ...}
// with boxes in 0-based pixel edges: (x0, y0) the top-left corner of the first pixel inside,
// (x1, y1) the bottom-right edge (exclusive), so width = x1 - x0.
//
// Scoring (PASCAL VOC): a detection is a true positive when its IoU with a person box not yet
// taken is at least the threshold (detections taken best score first); AP is the area under the
// precision/recall curve with the all-point interpolation (VOC 2010 on). Boxes of label
// "bicycle" are don't-care regions: riders often have no person box of their own, so a
// detection matching no person but overlapping a bicycle box by IoU >= the threshold is
// neither right nor wrong. Other labels (cars, ...) are background.
#include <filesystem>
#include <limits>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/detect/detectors.hpp"

namespace thermovis::detect {

struct AnnotatedFrame {
  std::string name;
  std::filesystem::path infrared;  // file; empty when the folder has none for this name
  std::filesystem::path visible;   // file; empty when the folder has no visible/ image of it
  std::vector<cv::Rect> persons;
  std::vector<cv::Rect> dont_care;
};

struct AnnotatedSet {
  std::vector<AnnotatedFrame> frames;  // sorted by name
  // Problems that left a frame out, each naming the file and the entry at fault.
  std::vector<std::string> errors;
};

// Reads dir/boxes.json and finds each entry's images. An entry that is malformed (not a list,
// a box that is not 4 numbers, x1 <= x0, a missing label) or whose infrared image is missing is
// reported in errors and left out; the rest is kept. Throws std::runtime_error when the folder
// or boxes.json cannot be read or boxes.json is not a JSON object.
AnnotatedSet load_annotated_set(const std::filesystem::path& dir);
// The same from the text of boxes.json; image paths are looked up under dir.
AnnotatedSet parse_annotated_set(const std::string& boxes_json, const std::filesystem::path& dir,
                                 const std::string& source_name = "boxes.json");

struct FrameImages {
  cv::Mat infrared;  // CV_8UC1 or CV_16UC1
  cv::Mat visible;   // CV_8UC3, or empty
};
// Reads a frame's images (colour-stored greyscale infrared becomes one channel; 16-bit PNG or
// TIFF infrared is kept as raw counts). Throws std::runtime_error naming the file when it cannot
// be read, is empty, is of another type or its size differs from the other band's, or when a
// box of the frame reaches outside the image.
FrameImages load_frame_images(const AnnotatedFrame& frame, bool need_visible);
// One image of either band, read as load_frame_images does (same errors).
cv::Mat read_infrared_image(const std::filesystem::path& file);  // CV_8UC1 or CV_16UC1
cv::Mat read_visible_image(const std::filesystem::path& file);   // CV_8UC3

// Training frames are never evaluation frames: a frame trains when the FNV-1a 32-bit hash of
// its name (the file stem, e.g. "010007") less its last character is even, else it evaluates.
// Names that differ only in the last character (ten consecutive frames of a numbered
// sequence) fall on the same side, so near-identical neighbours are not split between training
// and evaluation. The rule needs no list, splits any folder the same way every time and does
// not depend on the order of the names.
bool is_training_frame(const std::string& name);

struct FrameResult {
  std::vector<Detection> detections;
  std::vector<cv::Rect> persons;
  std::vector<cv::Rect> dont_care;
};

struct Figures {
  int persons = 0;         // person boxes counted
  int detections = 0;      // detections counted (those matched to don't-care boxes excluded)
  int true_positives = 0;  // at the detector's own operating point (all its boxes)
  double precision = 0.0;
  double recall = 0.0;
  double ap = 0.0;  // VOC all-point interpolated average precision
};

// Figures over the person boxes whose height (px) is in [min_height, max_height). A detection
// matched to a person outside that range is not counted; an unmatched detection counts as a
// false positive only when its own height is in the range.
Figures evaluate(const std::vector<FrameResult>& frames, double iou = 0.5, double min_height = 0.0,
                 double max_height = std::numeric_limits<double>::infinity());

}  // namespace thermovis::detect
