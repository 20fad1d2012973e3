#pragma once
// The Taylor (Scaramuzza / OCamCalib) projection, templated on the scalar as basalt-headers
// does: TaylorCamera runs it in double, the calibration's cost functions in Ceres Jets, so the
// model that is calibrated is the model that is used. Frames and parameters as in taylor.hpp:
// OCamCalib's sensor coordinates (u along rows, v along columns, w = pol(rho), a0 < 0), the
// shared camera frame x = v, y = u, z = -w. No Ceres here: a Jet scalar type only specialises
// ScalarValue where it is used.
#include <algorithm>
#include <cmath>
#include <type_traits>

namespace thermovis::camera::taylor {

// The double value of a scalar: the root search runs in double precision whatever T is.
// Automatic-differentiation types specialise this (the calibration does for Ceres Jets).
template <typename T>
struct ScalarValue {
  static double of(const T& x) { return x; }
};

template <typename T>
double value_of(const T& x) {
  return ScalarValue<T>::of(x);
}

// OCamCalib's affine between sensor (u, v) and pixel: [row; col] = [[c, d], [e, 1]] [u; v] +
// [xc; yc], px.
template <typename T>
struct Affine {
  T xc;  // centre row, px
  T yc;  // centre column, px
  T c, d, e;
};

// A model's parameters seen in scalar T: the polynomial a0, a1, ..., a_{count-1} (lowest order
// first) in the normalised radius rho / radius_scale (1 for coefficients in px).
template <typename T>
struct Parameters {
  Affine<T> affine;
  const T* pol = nullptr;
  int pol_count = 0;
  double radius_scale = 1.0;
};

// sum_k a[k] x^k over k < count (Horner).
template <typename T>
T polynomial(const T* a, int count, const T& x) {
  T value = a[count - 1];
  for (int k = count - 2; k >= 0; --k) value = value * x + a[k];
  return value;
}

// Its derivative, sum_k k a[k] x^(k-1).
template <typename T>
T polynomial_slope(const T* a, int count, const T& x) {
  T value = T(0);
  for (int k = count - 1; k >= 1; --k) value = value * x + static_cast<double>(k) * a[k];
  return value;
}

// Sensor (u, v) of a pixel (column, row).
template <typename T>
void pixel_to_sensor(const Affine<T>& a, const T& column, const T& row, T& u, T& v) {
  const T dr = row - a.xc, dc = column - a.yc;
  const T invdet = 1.0 / (a.c - a.d * a.e);
  u = invdet * (dr - a.d * dc);
  v = invdet * (-a.e * dr + a.c * dc);
}

// Pixel (column, row) of a sensor point (u, v).
template <typename T>
void sensor_to_pixel(const Affine<T>& a, const T& u, const T& v, T& column, T& row) {
  column = a.e * u + v + a.yc;
  row = a.c * u + a.d * v + a.xc;
}

// When Newton's method on the radius stops: |step| < tolerance + relative_tolerance * x
// (converged), or |slope| <= min_slope, a radius that is not positive and finite, or
// max_iterations steps (not converged).
struct RadiusSearch {
  int max_iterations = 8;
  double tolerance = 1e-10;
  double relative_tolerance = 0.0;
  double min_slope = 0.0;
};

struct RadiusRoot {
  double x = 0.0;  // the last iterate (normalised radius)
  bool converged = false;
};

// Root of g(x) = pol(x) - m x (m = w / sqrt(u^2 + v^2) of a ray, in normalised units) from x0.
inline RadiusRoot solve_radius(const double* pol, int count, double m, double x0,
                               const RadiusSearch& search) {
  RadiusRoot root{x0, false};
  for (int i = 0; i < search.max_iterations; ++i) {
    const double g = polynomial(pol, count, root.x) - m * root.x;
    const double dg = polynomial_slope(pol, count, root.x) - m;
    if (!(std::abs(dg) > search.min_slope)) return root;
    const double step = g / dg;
    root.x -= step;
    if (!(root.x > 0.0) || !std::isfinite(root.x)) return root;
    if (std::abs(step) < search.tolerance + search.relative_tolerance * root.x) {
      root.converged = true;
      return root;
    }
  }
  return root;
}

// The largest polynomial the projection takes in a scalar type other than double.
inline constexpr int kMaxDifferentiatedCoefficients = 16;

// The sensor radius (px, or the unit of the point) of a ray with m = w / sqrt(u^2 + v^2): the
// root of pol(rho) - m rho from the normalised start rho_start(m_normalised). Newton's method
// runs in double; for a T other than double one more Newton step in T from the converged root
// carries the exact derivatives (implicit function theorem). False when the search fails.
template <typename T, typename Start>
bool sensor_radius(const Parameters<T>& p, const T& m, Start rho_start, const RadiusSearch& search,
                   T& rho) {
  const T m_scaled = m * p.radius_scale;
  const double md = value_of(m_scaled);
  if constexpr (std::is_same_v<T, double>) {
    const RadiusRoot root = solve_radius(p.pol, p.pol_count, md, rho_start(md), search);
    if (!root.converged) return false;
    rho = root.x * p.radius_scale;
  } else {
    if (p.pol_count > kMaxDifferentiatedCoefficients) return false;
    double pd[kMaxDifferentiatedCoefficients];
    for (int k = 0; k < p.pol_count; ++k) pd[k] = value_of(p.pol[k]);
    const RadiusRoot root = solve_radius(pd, p.pol_count, md, rho_start(md), search);
    if (!root.converged) return false;
    const double dg = polynomial_slope(pd, p.pol_count, root.x) - md;
    const T x(root.x);
    const T rho_n = x - (polynomial(p.pol, p.pol_count, x) - m_scaled * x) / dg;
    rho = rho_n * p.radius_scale;
  }
  return true;
}

// Pixel (column, row) of a point in the shared camera frame (x right, y down, z forward; any
// unit). A point on the optical axis (within 1e-12 of its length) projects to the centre. False
// where the radius search fails; the caller checks the field of view.
template <typename T, typename Start>
bool project(const Parameters<T>& p, const T* point, Start rho_start, const RadiusSearch& search,
             T& column, T& row) {
  using std::hypot;
  const T U = point[1], V = point[0], W = -point[2];
  const T norm = hypot(U, V);
  const double len = std::sqrt(value_of(norm) * value_of(norm) + value_of(W) * value_of(W));
  T u(0.0), v(0.0);
  if (value_of(norm) > 1e-12 * len) {
    T rho;
    if (!sensor_radius(p, W / norm, rho_start, search, rho)) return false;
    u = U / norm * rho;
    v = V / norm * rho;
  }
  sensor_to_pixel(p.affine, u, v, column, row);
  return true;
}

}  // namespace thermovis::camera::taylor
