#pragma once
// Checkerboard inner-corner detection that also works on strongly distorted (fisheye and
// catadioptric) images.
//
// Tried in order, stopping at the first success:
//   1. OpenCV's classic detector (findChessboardCorners) and its sector-based detector
//      (findChessboardCornersSB) on several preprocessed versions of the image (plain, CLAHE,
//      upscaled, blurred, inverted: the last for heated boards seen in infrared, where dark
//      and light squares swap);
//   2. for catadioptric images, where a board bends around the mirror axis, the same detectors
//      on a polar unwrapping of the image about its centre (a panorama, in which the board is
//      close to a perspective view), corners mapped back to the raw image.
// Every result is refined to sub-pixel in the raw image with a window sized per corner from the
// local corner spacing, checked for consistency (no merged corners, regular neighbour spacing),
// and put into a canonical order (see canonical_order()). Each corner must then be a saddle of
// the image and agree with a quadratic fit of its grid neighbours; one that fails is predicted
// from its neighbours and refined again, or else marked missing (NaN; at most 10 % of the
// corners, else the detection is rejected).
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "thermovis/calib/board.hpp"

namespace thermovis::calib {

struct ChessboardDetection {
  bool found = false;
  std::vector<Eigen::Vector2d> corners;  // board order, (x = column, y = row), px; NaN = missing
  int missing = 0;                       // corners that failed the checks (at most 10 %)
  std::string method;                    // which detector/preprocessing succeeded
};

struct ChessboardOptions {
  bool try_polar_unwrap = true;  // the catadioptric fallback (step 2)
};

// `image`: 8-bit grey or BGR, or 16-bit grey (scaled to 8 bit by its range). Throws
// std::invalid_argument for an empty image or an unsupported type; a board that is not seen
// gives found = false.
ChessboardDetection detect_chessboard(const cv::Mat& image, cv::Size inner_corners,
                                      const ChessboardOptions& options = {});

// Refines corners in place to sub-pixel with cv::cornerSubPix, one window per corner of half
// size 0.35 x the distance to its nearest grid neighbour (2..11 px). `grey` is 8-bit.
void refine_corners(const cv::Mat& grey, cv::Size inner_corners,
                    std::vector<Eigen::Vector2d>& corners);

// Re-labels a grid of corners (board order) by one of the board's symmetries so that the
// board's x axis points to the image's right and its y axis down as far as possible (ties
// broken towards x down / y right). Two cameras that see the board from the same side then
// label each physical corner alike, which stereo calibration needs.
void canonical_order(cv::Size inner_corners, std::vector<Eigen::Vector2d>& corners);

// Loads an image (any format OpenCV reads). Throws std::runtime_error naming the file when it
// is missing or unreadable.
cv::Mat read_image(const std::string& path);

// Image files of a folder (.png .jpg .jpeg .bmp .tif .tiff .pgm .ppm), in natural order
// (image2 before image10). Throws std::runtime_error when the folder is missing or has none.
std::vector<std::string> list_image_files(const std::string& folder);

}  // namespace thermovis::calib
