#include "thermovis/camera/taylor.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "thermovis/camera/taylor_projection.hpp"

namespace thermovis::camera {
namespace {

double horner(const std::vector<double>& coeffs, double x) {
  return taylor::polynomial(coeffs.data(), static_cast<int>(coeffs.size()), x);
}

// The model's parameters for the shared projection (coefficients in px).
taylor::Parameters<double> parameters(const TaylorIntrinsics& in) {
  return {{in.xc, in.yc, in.c, in.d, in.e}, in.pol.data(), static_cast<int>(in.pol.size()), 1.0};
}

// Newton's method on the sensor radius, px: from the inverse polynomial's estimate (within
// about 2e-3 px of the root) a few steps reach 1e-10 px.
constexpr taylor::RadiusSearch kRadiusSearch{8, 1e-10, 0.0, 0.0};

void require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("Taylor camera: " + what);
}

// Farthest image corner from the centre, in sensor radius (px), through the inverse affine.
double corner_radius(const TaylorIntrinsics& in) {
  const taylor::Affine<double> affine{in.xc, in.yc, in.c, in.d, in.e};
  double rmax = 0.0;
  for (double row : {-0.5, in.height - 0.5}) {
    for (double col : {-0.5, in.width - 0.5}) {
      double u = 0.0, v = 0.0;
      taylor::pixel_to_sensor(affine, col, row, u, v);
      rmax = std::max(rmax, std::hypot(u, v));
    }
  }
  return rmax;
}

}  // namespace

TaylorCamera::TaylorCamera(TaylorIntrinsics intrinsics) : intr_(std::move(intrinsics)) {
  require(intr_.width > 0 && intr_.height > 0, "image size must be positive");
  require(intr_.width <= kMaxImageSide && intr_.height <= kMaxImageSide,
          "image size " + std::to_string(intr_.width) + "x" + std::to_string(intr_.height) +
              " is over " + std::to_string(kMaxImageSide) + " px a side");
  require(intr_.pol.size() >= 2, "polynomial needs at least a0 and a1");
  for (double a : intr_.pol) require(std::isfinite(a), "polynomial coefficient is not finite");
  for (double a : intr_.invpol)
    require(std::isfinite(a), "inverse polynomial coefficient is not finite");
  require(std::isfinite(intr_.xc) && std::isfinite(intr_.yc), "centre is not finite");
  require(std::isfinite(intr_.c) && std::isfinite(intr_.d) && std::isfinite(intr_.e),
          "affine c, d, e not finite");
  require(intr_.pol[0] < 0.0, "a0 must be negative (OCamCalib's optical axis is -z)");
  require(std::abs(intr_.c - intr_.d * intr_.e) > 1e-6,
          "affine matrix [[c, d], [e, 1]] is singular");

  // The valid radius: just beyond the farthest corner, cut where the angle stops growing
  // (past that the polynomial no longer describes a lens).
  rho_max_ = corner_radius(intr_) + 2.0;
  const int steps = 4000;
  double last = field_angle_at_radius(0.0);
  for (int i = 1; i <= steps; ++i) {
    const double rho = rho_max_ * i / steps;
    const double phi = field_angle_at_radius(rho);
    if (!(phi > last)) {
      rho_max_ = rho_max_ * (i - 1) / steps;
      break;
    }
    last = phi;
  }
  require(rho_max_ > 1.0, "polynomial is not monotonic near the centre");
  max_angle_ = field_angle_at_radius(rho_max_);
  if (intr_.invpol.empty()) {
    intr_.invpol = fit_inverse_polynomial(intr_.pol, rho_max_).coefficients;
  }
}

int TaylorCamera::parameter_count() const {
  // a0, a2.. (a1 fixed at 0), centre (2), affine c, d, e (3).
  return static_cast<int>(intr_.pol.size()) - 1 + 5;
}

std::unique_ptr<CameraModel> TaylorCamera::clone() const {
  return std::make_unique<TaylorCamera>(*this);
}

double TaylorCamera::invpol_at(double theta) const { return horner(intr_.invpol, theta); }

double TaylorCamera::field_angle_at_radius(double rho) const {
  return std::atan2(rho, -horner(intr_.pol, rho));
}

double TaylorCamera::radius_at_field_angle(double phi) const {
  // phi = atan2(rho, -pol(rho)) <=> pol(rho) + rho / tan(phi) = 0, i.e. m = -1/tan(phi).
  if (phi <= 0.0) return 0.0;
  const double m = -std::cos(phi) / std::sin(phi);
  return taylor::solve_radius(intr_.pol.data(), static_cast<int>(intr_.pol.size()), m,
                              radius_start(m), kRadiusSearch)
      .x;
}

double TaylorCamera::radius_start(double m) const {
  return std::clamp(invpol_at(std::atan(m)), 0.0, rho_max_ * 1.5);
}

bool TaylorCamera::unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d& ray) const {
  if (!pixel.allFinite()) return false;
  double u = 0.0, v = 0.0;
  taylor::pixel_to_sensor(parameters(intr_).affine, pixel.x(), pixel.y(), u, v);
  const double rho = std::hypot(u, v);
  if (rho > rho_max_) return false;
  const double w = horner(intr_.pol, rho);
  ray = Eigen::Vector3d(v, u, -w).normalized();
  return true;
}

bool TaylorCamera::project(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const {
  if (!ray.allFinite()) return false;
  const double norm = std::hypot(ray.y(), ray.x()), W = -ray.z();
  if (std::sqrt(norm * norm + W * W) == 0.0) return false;
  if (std::atan2(norm, -W) > max_angle_ + 1e-9) return false;
  return taylor::project(
      parameters(intr_), ray.data(), [this](double m) { return radius_start(m); }, kRadiusSearch,
      pixel.x(), pixel.y());
}

bool TaylorCamera::project_invpol(const Eigen::Vector3d& ray, Eigen::Vector2d& pixel) const {
  if (!ray.allFinite()) return false;
  const double U = ray.y(), V = ray.x(), W = -ray.z();
  const double norm = std::hypot(U, V);
  if (std::atan2(norm, -W) > max_angle_ + 1e-9) return false;
  double u = 0.0, v = 0.0;
  if (norm > 0.0) {
    const double rho = invpol_at(std::atan(W / norm));
    u = U / norm * rho;
    v = V / norm * rho;
  }
  taylor::sensor_to_pixel(parameters(intr_).affine, u, v, pixel.x(), pixel.y());
  return true;
}

InversePolynomialFit TaylorCamera::fit_inverse_polynomial(const std::vector<double>& pol,
                                                          double rho_max, double tolerance_px,
                                                          int max_degree) {
  auto theta_of = [&pol](double r) { return std::atan2(horner(pol, r), r); };  // -pi/2 at 0
  // theta(rho) is monotonic on [0, rho_max]: invert it by bisection.
  auto rho_of = [&](double theta) {
    double lo = 0.0, hi = rho_max;
    const bool increasing = theta_of(rho_max) > theta_of(0.0);
    for (int i = 0; i < 100; ++i) {
      const double mid = 0.5 * (lo + hi);
      ((theta_of(mid) < theta) == increasing ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  const double theta_a = theta_of(0.0), theta_b = theta_of(rho_max);
  const double centre = 0.5 * (theta_a + theta_b), half = 0.5 * (theta_b - theta_a);
  // Chebyshev nodes in theta (near-minimax least squares), fitted in t = (theta - centre) / half
  // for conditioning; the result is expanded to monomials in theta, OCamCalib's storage.
  const int samples = 400;
  Eigen::VectorXd t(samples), rho(samples);
  for (int i = 0; i < samples; ++i) {
    t[i] = std::cos(M_PI * (i + 0.5) / samples);
    rho[i] = rho_of(centre + half * t[i]);
  }
  const int checks = 2000;
  InversePolynomialFit best;
  best.rho_max_px = rho_max;
  best.max_error_px = std::numeric_limits<double>::infinity();
  for (int degree = 3; degree <= max_degree; ++degree) {
    Eigen::MatrixXd A(samples, degree + 1);
    for (int i = 0; i < samples; ++i) {
      double p = 1.0;
      for (int k = 0; k <= degree; ++k, p *= t[i]) A(i, k) = p;
    }
    const Eigen::VectorXd b = A.colPivHouseholderQr().solve(rho);
    // sum_k b_k ((theta - centre) / half)^k expanded by the binomial theorem.
    std::vector<double> coeffs(degree + 1, 0.0);
    for (int k = 0; k <= degree; ++k) {
      const double bk = b[k] / std::pow(half, k);
      double binom = 1.0;  // C(k, j)
      for (int j = 0; j <= k; ++j) {
        coeffs[j] += bk * binom * std::pow(-centre, k - j);
        binom = binom * (k - j) / (j + 1);
      }
    }
    double err = 0.0;
    for (int i = 0; i < checks; ++i) {
      const double r = rho_max * i / (checks - 1);
      err = std::max(err, std::abs(horner(coeffs, theta_of(r)) - r));
    }
    if (err < best.max_error_px) {
      best.coefficients = coeffs;
      best.max_error_px = err;
    }
    if (err < tolerance_px) break;
  }
  return best;
}

}  // namespace thermovis::camera
