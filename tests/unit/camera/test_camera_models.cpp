// One typed suite that every camera model passes: round trips both ways over the image.
#include <gtest/gtest.h>

#include <memory>

#include "thermovis/camera/rectified.hpp"
#include "thermovis/camera/taylor.hpp"

namespace tc = thermovis::camera;

namespace {

// The paper's left visible camera (Table 4).
tc::TaylorIntrinsics paper_visible_left() {
  tc::TaylorIntrinsics in;
  in.width = 1920;
  in.height = 1080;
  in.xc = 487.0978;
  in.yc = 964.3319;
  in.c = 1.0001;
  in.d = -1.2e-5;
  in.e = 1.7e-5;
  in.pol = {-835.384, 0, 3.296e-4, 3.290e-7, -3.189e-10};
  return in;
}

struct TaylorFactory {
  static std::unique_ptr<tc::CameraModel> make() {
    return std::make_unique<tc::TaylorCamera>(paper_visible_left());
  }
};
struct EquirectangularFactory {
  static std::unique_ptr<tc::CameraModel> make() {
    return std::make_unique<tc::RectifiedCamera>(tc::RectifiedIntrinsics{
        1920, 1080, 850.0, 959.5, 539.5, tc::RectifiedProjection::equirectangular});
  }
};
struct CylindricalFactory {
  static std::unique_ptr<tc::CameraModel> make() {
    return std::make_unique<tc::RectifiedCamera>(tc::RectifiedIntrinsics{
        1280, 720, 500.0, 639.5, 359.5, tc::RectifiedProjection::cylindrical});
  }
};

template <typename Factory>
class CameraModelTest : public ::testing::Test {
 protected:
  std::unique_ptr<tc::CameraModel> model = Factory::make();
};

using Models = ::testing::Types<TaylorFactory, EquirectangularFactory, CylindricalFactory>;
TYPED_TEST_SUITE(CameraModelTest, Models);

TYPED_TEST(CameraModelTest, PixelRayPixelRoundTrip) {
  const cv::Size size = this->model->image_size();
  double worst = 0.0;
  int checked = 0;
  for (int y = 0; y < size.height; y += 7) {
    for (int x = 0; x < size.width; x += 7) {
      Eigen::Vector3d ray;
      Eigen::Vector2d back;
      ASSERT_TRUE(this->model->unproject({x, y}, ray)) << x << "," << y;
      EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
      ASSERT_TRUE(this->model->project(ray, back)) << x << "," << y;
      worst = std::max(worst, (back - Eigen::Vector2d(x, y)).norm());
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
  EXPECT_LT(worst, 1e-6) << this->model->name();
}

TYPED_TEST(CameraModelTest, RayPixelRayRoundTripAndScaleInvariance) {
  Eigen::Vector3d centre_ray;
  const cv::Size size = this->model->image_size();
  ASSERT_TRUE(this->model->unproject({size.width / 2.0, size.height / 2.0}, centre_ray));
  for (double ax : {-0.6, -0.2, 0.0, 0.3, 0.7}) {
    for (double ay : {-0.4, 0.0, 0.35}) {
      const Eigen::Vector3d ray = Eigen::Vector3d(std::tan(ax), std::tan(ay), 1.0).normalized();
      Eigen::Vector2d px, px_scaled;
      ASSERT_TRUE(this->model->project(ray, px));
      ASSERT_TRUE(this->model->project(ray * 12.5, px_scaled));
      EXPECT_LT((px - px_scaled).norm(), 1e-9);
      Eigen::Vector3d back;
      ASSERT_TRUE(this->model->unproject(px, back));
      EXPECT_LT((back - ray).norm(), 1e-9) << this->model->name() << " ax=" << ax << " ay=" << ay;
    }
  }
}

TYPED_TEST(CameraModelTest, RejectsNonFiniteInput) {
  Eigen::Vector3d ray;
  Eigen::Vector2d px;
  EXPECT_FALSE(this->model->unproject({std::nan(""), 3.0}, ray));
  EXPECT_FALSE(this->model->project({std::nan(""), 0.0, 1.0}, px));
  EXPECT_FALSE(this->model->project({0.0, 0.0, 0.0}, px));
  EXPECT_GT(this->model->parameter_count(), 0);
  EXPECT_FALSE(this->model->name().empty());
  EXPECT_EQ(this->model->clone()->image_size(), this->model->image_size());
}

}  // namespace

namespace {

// A scaled grid sees the same ray at the scaled pixel position.
TEST(RectifiedGrid, ScalingKeepsTheFieldAndPixelCentres) {
  const tc::RectifiedIntrinsics full{1870,  1280,  835.4,
                                     930.2, 611.7, tc::RectifiedProjection::equirectangular};
  const tc::RectifiedIntrinsics half = tc::scaled(full, 0.5);
  EXPECT_EQ(half.width, 936);
  EXPECT_EQ(half.height, 640);
  const tc::RectifiedCamera a(full), b(half);
  for (const Eigen::Vector2d& px : {Eigen::Vector2d(0, 0), Eigen::Vector2d(1000.5, 300.25)}) {
    Eigen::Vector3d ray;
    ASSERT_TRUE(a.unproject(px, ray));
    Eigen::Vector2d in_half;
    ASSERT_TRUE(b.project(ray, in_half));
    EXPECT_NEAR(in_half.x(), (px.x() + 0.5) * 0.5 - 0.5, 1e-9);
    EXPECT_NEAR(in_half.y(), (px.y() + 0.5) * 0.5 - 0.5, 1e-9);
  }
  EXPECT_THROW(tc::scaled(full, 0.0), std::invalid_argument);
}

}  // namespace
