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
// model (radial function, centred on the image centre): the target is the axis-scaled pinhole
// that keeps the image's full width and height, a ray (X, Y, Z) going to
//   x = fx X / Z, y = fy Y / Z,   fx = a / tan(phi(a)), fy = b / tan(phi(b))
// (phi(rho) = the Taylor model's field angle at sensor radius rho): straight lines stay straight
// and the edge midpoints stay at the edge midpoints, so no field is lost along the axes.
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
  double target_fx_px = 0.0, target_fy_px = 0.0;  // the axis-scaled pinhole fitted to
  double rms_px = 0.0;  // RMS distance between model and target raw positions, px
  double max_px = 0.0;  // largest such distance over the samples
  int samples = 0;      // output pixels compared (every 8th in each direction)
};

// Throws std::invalid_argument when the lens does not reach the image edges' field angles.
EllipticalFit fit_elliptical_model(const camera::TaylorCamera& camera);

// Raw position (px, x = column, y = row) of corrected pixel (u, v).
cv::Point2d elliptical_source(const EllipticalModel& model, double u, double v);

// The correction map (CV_32FC2, image_size, raw positions); computed on the top-left quadrant
// and mirrored exactly, so its fixed-point table is exactly quarter symmetric.
cv::Mat build_elliptical_map(const EllipticalModel& model);

}  // namespace thermovis::rectify
