#pragma once
// The paper's own distortion correction (Section 2.2, Eq. 20-21, "approximate elliptical
// distortion correction model"), as an alternative to the Taylor-model rectification.
//
// Reading of the equations used here. For a corrected (output) pixel (u, v) of a W x H image,
// (x, y) = (u - cx, v - cy) with the centre (cx, cy) = ((W - 1) / 2, (H - 1) / 2), and
//   r = sqrt(x^2 / a^2 + y^2 / b^2),   a = W / 2, b = H / 2                     (Eq. 21)
// (the paper names a = H/2 with H the image height but uses H x V = 1920 x 1080; a is taken
// along the image's long, horizontal axis). Eq. 20, x = k2 x_d / (1 + k1 (r - R)^2), with r from
// the corrected (x, y) as Eq. 21 writes it, solves directly for the distorted (raw) position:
//   x_d = x (1 + k1 (r - R)^2) / k2,   y_d = y (1 + k1 (r - R)^2) / k2
// so the remap table needs no iteration. The model is centred on the image centre, which makes
// its table mirror symmetric in both axes: the quarter table of the paper's Fig. 14.
//
// The paper gives no values for k1, k2, R: fit_elliptical_model fits them to the camera's Taylor
// model (its radial function, centred on the image centre). The target is the pinhole that keeps
// the image's full width: a ray at angle phi from the axis goes to radius f tan(phi), with
// f = a / tan(phi(a)) (phi(rho) = the lens's field angle at sensor radius rho), so the side
// edges' midpoints stay at the side edges and no horizontal field is lost. The model keeps the
// direction of each pixel from the centre, as the pinhole does; the fit (linear least squares in
// 1/k2 and k1/k2 for each R, R by a scan and golden section) minimises the distance between the
// model's and the pinhole's raw positions over every 8th output pixel whose pinhole position is
// inside the raw image, with the side edges' midpoints held. Paper rig: visible left k1 = 0.825,
// k2 = 1.049, R = 1.245, RMS 46 px; infrared left k1 = 0.448, k2 = 1.108, R = 1.491, RMS 18 px.
// Three parameters on an elliptical radius cannot follow the pinhole closely (the paper: "the
// edges of the image are still aberrated, but the field-of-view is increased"); the Taylor
// rectification (rig_rectification.hpp) is the exact correction.
#include <opencv2/core/mat.hpp>

#include "thermovis/camera/taylor.hpp"

namespace thermovis::rectify {

struct EllipticalModel {
  cv::Size image_size;  // W x H, px: the raw and the corrected image
  double k1 = 0.0;      // Eq. 20, dimensionless (r is dimensionless)
  double k2 = 1.0;      // Eq. 20, dimensionless scale
  double R = 0.0;       // Eq. 20, dimensionless radius offset
};

struct EllipticalFit {
  EllipticalModel model;
  double target_f_px = 0.0;  // the pinhole fitted to, px
  double rms_px = 0.0;       // RMS distance between model and target raw positions, px
  double max_px = 0.0;       // largest such distance over the samples
  int samples = 0;           // output pixels compared (every 8th in each direction)
};

// Throws std::invalid_argument when the lens's field at the side edges is not below 90 deg.
EllipticalFit fit_elliptical_model(const camera::TaylorCamera& camera);

// Raw position (px, x = column, y = row) of corrected pixel (u, v).
cv::Point2d elliptical_source(const EllipticalModel& model, double u, double v);

// The correction map (CV_32FC2, image_size, raw positions); computed on the top-left quadrant
// and mirrored exactly, so its fixed-point table is exactly quarter symmetric.
cv::Mat build_elliptical_map(const EllipticalModel& model);

}  // namespace thermovis::rectify
