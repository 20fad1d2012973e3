#pragma once
// Field of view and distortion figures of a Taylor camera, as the paper's Tables 1 and 2 state
// them.
#include "thermovis/camera/taylor.hpp"

namespace thermovis::camera {

struct FieldFigures {
  double horizontal_deg =
      0.0;  // angle between the rays of the first and last column, on the centre row
  double vertical_deg = 0.0;  // same for the first and last row, on the centre column
  double diagonal_deg = 0.0;  // largest angle between rays of opposite corners
  // Distortion at the image corner farthest from the centre: (r - r_ideal) / r_ideal, with
  // r_ideal = |a0| tan(phi), the pinhole with the model's paraxial focal length |a0| px.
  double corner_distortion = 0.0;
  double corner_angle_deg = 0.0;     // that corner's angle from the optical axis
  double paraxial_focal_px = 0.0;    // |a0|
  double invpol_max_error_px = 0.0;  // largest |project_invpol - project| over the image's pixels
};

// Samples every `stride`-th pixel of the image for the inverse polynomial error (1 = every pixel).
FieldFigures field_figures(const TaylorCamera& camera, int stride = 4);

}  // namespace thermovis::camera
