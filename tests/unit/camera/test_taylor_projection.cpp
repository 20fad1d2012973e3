// The shared Taylor projection (taylor_projection.hpp) in a scalar type other than double, as the
// calibration runs it in Ceres Jets: a forward-mode dual number here, so the camera tests need
// no Ceres. Its values must be TaylorCamera's, and its derivatives those of TaylorCamera's
// projection by finite differences (with respect to the point and to a polynomial coefficient).
#include <gtest/gtest.h>

#include <cmath>

#include "thermovis/camera/taylor.hpp"
#include "thermovis/camera/taylor_projection.hpp"
#include "thermovis/test/paper_rig.hpp"

namespace {

// A value and its derivative along one direction.
struct Dual {
  double a = 0.0, v = 0.0;
  Dual() = default;
  explicit Dual(double value, double derivative = 0.0) : a(value), v(derivative) {}
};
Dual operator+(Dual x, Dual y) { return Dual(x.a + y.a, x.v + y.v); }
Dual operator-(Dual x, Dual y) { return Dual(x.a - y.a, x.v - y.v); }
Dual operator-(Dual x) { return Dual(-x.a, -x.v); }
Dual operator*(Dual x, Dual y) { return Dual(x.a * y.a, x.v * y.a + x.a * y.v); }
Dual operator*(Dual x, double s) { return Dual(x.a * s, x.v * s); }
Dual operator/(Dual x, Dual y) { return Dual(x.a / y.a, (x.v * y.a - x.a * y.v) / (y.a * y.a)); }
Dual operator/(Dual x, double s) { return Dual(x.a / s, x.v / s); }
Dual hypot(Dual x, Dual y) {
  const double h = std::hypot(x.a, y.a);
  return Dual(h, (x.a * x.v + y.a * y.v) / h);
}

}  // namespace

template <>
struct thermovis::camera::taylor::ScalarValue<Dual> {
  static double of(const Dual& x) { return x.a; }
};

namespace {

namespace tc = thermovis::camera;
namespace taylor = thermovis::camera::taylor;

using thermovis::test::paper_taylor_camera;

// Projects `point` with the shared template in Dual, the derivative seeded on point[axis]
// (axis 0..2) or on polynomial coefficient `coefficient` (axis -1).
bool project_dual(const tc::TaylorCamera& cam, const Eigen::Vector3d& point, int axis,
                  int coefficient, Dual& column, Dual& row) {
  const tc::TaylorIntrinsics& in = cam.intrinsics();
  std::vector<Dual> pol;
  for (std::size_t k = 0; k < in.pol.size(); ++k)
    pol.emplace_back(in.pol[k], axis < 0 && static_cast<int>(k) == coefficient ? 1.0 : 0.0);
  const taylor::Parameters<Dual> p{{Dual(in.xc), Dual(in.yc), Dual(in.c), Dual(in.d), Dual(in.e)},
                                   pol.data(),
                                   static_cast<int>(pol.size()),
                                   1.0};
  Dual x[3];
  for (int i = 0; i < 3; ++i) x[i] = Dual(point[i], i == axis ? 1.0 : 0.0);
  // Started from the forward model's own root, so the search converges at once.
  Eigen::Vector2d start;
  if (!cam.project(point, start)) return false;
  double u = 0.0, v = 0.0;
  taylor::pixel_to_sensor(taylor::Affine<double>{in.xc, in.yc, in.c, in.d, in.e}, start.x(),
                          start.y(), u, v);
  const double rho = std::hypot(u, v);
  return taylor::project(
      p, x, [rho](double) { return rho; }, taylor::RadiusSearch{}, column, row);
}

TEST(TaylorProjection, ADualScalarGivesTheCameraPixelAndItsDerivatives) {
  for (const char* name : {"visible.left", "infrared.right"}) {
    const tc::TaylorCamera& cam = paper_taylor_camera(name);
    for (const Eigen::Vector3d& point :
         {Eigen::Vector3d(0.3, -0.2, 5.0), Eigen::Vector3d(-4.0, 1.5, 3.0),
          Eigen::Vector3d(2.0, 1.0, 1.5)}) {
      Eigen::Vector2d px;
      ASSERT_TRUE(cam.project(point, px)) << name;
      for (int axis = 0; axis < 3; ++axis) {
        Dual column, row;
        ASSERT_TRUE(project_dual(cam, point, axis, 0, column, row)) << name;
        EXPECT_NEAR(column.a, px.x(), 1e-9) << name;
        EXPECT_NEAR(row.a, px.y(), 1e-9) << name;
        // Central differences of the double projection, step 1e-5 of the point's unit.
        const double h = 1e-5;
        Eigen::Vector3d ahead = point, behind = point;
        ahead[axis] += h;
        behind[axis] -= h;
        Eigen::Vector2d pa, pb;
        ASSERT_TRUE(cam.project(ahead, pa) && cam.project(behind, pb));
        const Eigen::Vector2d numeric = (pa - pb) / (2.0 * h);
        EXPECT_NEAR(column.v, numeric.x(), 1e-4 * (1.0 + std::abs(numeric.x())))
            << name << " axis " << axis;
        EXPECT_NEAR(row.v, numeric.y(), 1e-4 * (1.0 + std::abs(numeric.y())))
            << name << " axis " << axis;
      }
      // With respect to a2 (px^-1): the camera rebuilt with a2 moved both ways.
      const int k = 2;
      Dual column, row;
      ASSERT_TRUE(project_dual(cam, point, -1, k, column, row)) << name;
      const double h = 1e-6 * std::abs(cam.intrinsics().pol[k]);
      tc::TaylorIntrinsics up = cam.intrinsics(), down = cam.intrinsics();
      up.pol[k] += h;
      down.pol[k] -= h;
      Eigen::Vector2d pa, pb;
      ASSERT_TRUE(tc::TaylorCamera(up).project(point, pa) &&
                  tc::TaylorCamera(down).project(point, pb));
      const Eigen::Vector2d numeric = (pa - pb) / (2.0 * h);
      EXPECT_NEAR(column.v, numeric.x(), 1e-4 * std::abs(numeric.x()) + 1e-3) << name;
      EXPECT_NEAR(row.v, numeric.y(), 1e-4 * std::abs(numeric.y()) + 1e-3) << name;
      EXPECT_GT(std::abs(column.v) + std::abs(row.v), 10.0) << name;  // a2 matters off-axis
    }
  }
}

}  // namespace
