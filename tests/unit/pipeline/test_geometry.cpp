// The pipeline geometry: what rectify-fuse makes from the rig and publishes, and what every
// other stage, tool and DDS application turns pixels into rays with.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "thermovis/pipeline/geometry.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace pl = thermovis::pipeline;

namespace {

const thermovis::camera::Rig& rig() {
  static const auto r = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  return r;
}

}  // namespace

TEST(PipelineGeometry, BothPairsShareTheGridAndItsRotation) {
  const pl::PipelineGeometry g = pl::make_geometry(rig(), {});
  EXPECT_NO_THROW(pl::validate(g, {1920, 1088}));
  // The paper rig's baselines: visible 0.336 m; the infrared pair's component along the visible
  // baseline is a little shorter than its 0.358 m (the two baselines differ in direction).
  EXPECT_NEAR(g.visible.baseline_m, 0.336, 0.002);
  EXPECT_GT(g.infrared.baseline_m, 0.30);
  EXPECT_LT(g.infrared.baseline_m, 0.36);
  EXPECT_TRUE(g.infrared.T_ref_left_rect.linear().isApprox(g.visible.T_ref_left_rect.linear()));
  EXPECT_TRUE(g.infrared.T_ref_right_rect.linear().isApprox(g.visible.T_ref_left_rect.linear()));
  // Each pair's frames are centred on its own cameras.
  EXPECT_TRUE(g.infrared.T_ref_left_rect.translation().isApprox(
      rig().camera(rig().infrared.left).T_ref_cam.translation()));
  // The infrared right eye is off the grid's x axis: its points are triangulated from there.
  EXPECT_GT(g.ranging(pl::Band::infrared).right_centre_m.tail<2>().norm(), 0.01);
  EXPECT_EQ(g.ranging(pl::Band::visible).right_centre_m.norm(), 0.0);
  // The default grid is half the visible camera's resolution; the full one twice as wide.
  const pl::PipelineGeometry full = pl::make_geometry(rig(), {1.0});
  EXPECT_NEAR(full.grid.f, 2 * g.grid.f, 1e-9);
  EXPECT_NEAR(full.grid.width, 2 * g.grid.width, 2);
}

TEST(PipelineGeometry, TheIdIsADigestOfEveryField) {
  const pl::PipelineGeometry g = pl::make_geometry(rig(), {});
  EXPECT_EQ(g.id(), pl::make_geometry(rig(), {}).id());  // the same options, the same id
  EXPECT_NE(g.id(), 0u);
  pl::PipelineGeometry other = g;
  other.grid.cx += 0.5;
  EXPECT_NE(other.id(), g.id());
  other = g;
  other.infrared.baseline_m += 1e-6;
  EXPECT_NE(other.id(), g.id());
  other = g;
  other.visible.left_camera = "another";
  EXPECT_NE(other.id(), g.id());
  EXPECT_NE(pl::make_geometry(rig(), {0.25}).id(), g.id());
}

TEST(PipelineGeometry, TheInfraredPairIsAtItsCamerasOwnResolution) {
  // The pipeline grid is about the infrared cameras' own px per rad: their images are on it.
  const pl::PipelineGeometry g = pl::make_geometry(rig(), {});
  EXPECT_EQ(g.infrared_reduction, 1);
  EXPECT_EQ(g.image_size(pl::Band::infrared), g.grid_size());
  // The visible camera's full grid has twice theirs: the infrared images are it reduced by 2.
  const pl::PipelineGeometry full = pl::make_geometry(rig(), {1.0});
  ASSERT_EQ(full.infrared_reduction, 2);
  EXPECT_EQ(full.image_size(pl::Band::infrared),
            cv::Size(full.grid.width / 2, full.grid.height / 2));
  EXPECT_EQ(full.image_size(pl::Band::visible), full.grid_size());
  EXPECT_EQ(full.image_size(pl::Band::fused), full.grid_size());
  // A reduced pixel sees along the ray of its block's centre on the grid.
  const thermovis::camera::RectifiedCamera reduced(full.image_grid(pl::Band::infrared));
  const thermovis::camera::RectifiedCamera grid(full.grid);
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(10, 20), Eigen::Vector2d(400.25, 300.5)}) {
    Eigen::Vector3d a, b;
    ASSERT_TRUE(reduced.unproject(p, a));
    ASSERT_TRUE(grid.unproject(
        Eigen::Vector2d(pl::grid_coordinate(p.x(), 2), pl::grid_coordinate(p.y(), 2)), b));
    EXPECT_LT((a - b).norm(), 1e-12) << p.transpose();
  }
  // A grid box on a reduced image: every reduced pixel it touches.
  EXPECT_EQ(pl::reduce_box({3, 4, 5, 6}, 2), cv::Rect(1, 2, 3, 3));
  EXPECT_EQ(pl::reduce_box({-3, 4, 2, 2}, 2), cv::Rect(-2, 2, 2, 1));
  EXPECT_EQ(pl::reduce_box({3, 4, 5, 6}, 1), cv::Rect(3, 4, 5, 6));
  // The reduction is asked for, or the infrared kept on the grid; it is part of the digest.
  pl::GridOptions on_grid;
  on_grid.scale = 1.0;
  on_grid.infrared_reduction = 1;
  const pl::PipelineGeometry full_on_grid = pl::make_geometry(rig(), on_grid);
  EXPECT_EQ(full_on_grid.infrared_reduction, 1);
  EXPECT_NE(full_on_grid.id(), full.id());
  on_grid.infrared_reduction = 9;
  EXPECT_THROW(pl::make_geometry(rig(), on_grid), std::invalid_argument);
  on_grid.infrared_reduction = -1;
  EXPECT_THROW(pl::make_geometry(rig(), on_grid), std::invalid_argument);
}

TEST(PipelineGeometry, ValidateNamesWhatIsWrong) {
  const pl::PipelineGeometry good = pl::make_geometry(rig(), {});
  auto rejects = [&](const pl::PipelineGeometry& g, const std::string& word) {
    try {
      pl::validate(g, {1920, 1088});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(word) != std::string::npos;
    }
    return false;
  };
  pl::PipelineGeometry g = good;
  g.grid.f = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(rejects(g, "f"));
  g = good;
  g.grid.width = 4000;
  EXPECT_TRUE(rejects(g, "larger than"));
  g = good;
  g.infrared.baseline_m = -0.3;
  EXPECT_TRUE(rejects(g, "infrared pair: baseline"));
  g = good;
  g.visible.T_ref_right_rect.linear() *= 2.0;
  EXPECT_TRUE(rejects(g, "not a rotation"));
  g = good;
  g.infrared.T_ref_left_rect.linear() =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_TRUE(rejects(g, "do not share"));
  g = good;
  g.infrared_reduction = 0;
  EXPECT_TRUE(rejects(g, "infrared reduction"));
  g.infrared_reduction = 200;
  EXPECT_TRUE(rejects(g, "infrared reduction"));
}

TEST(PipelineGeometry, RawBoxesLandOnTheGridAndTheSearchCoversTheNearest) {
  const pl::PipelineGeometry g = pl::make_geometry(rig(), {});
  const cv::Rect grid(cv::Point(0, 0), g.grid_size());
  // The middle of each left camera is inside the grid.
  for (const pl::Band band : {pl::Band::visible, pl::Band::infrared}) {
    const auto& cam =
        rig().camera(band == pl::Band::visible ? rig().visible.left : rig().infrared.left);
    const cv::Size s = cam.model->image_size();
    const cv::Rect box = pl::raw_box_on_grid(g, rig(), band, s.width * 0.45, s.height * 0.4,
                                             s.width * 0.55, s.height * 0.6);
    EXPECT_FALSE(box.empty());
    EXPECT_EQ(box & grid, box) << pl::band_name(band);
  }
  // The search reaches the disparity of a target at the nearest distance on either pair.
  const double d = pl::max_disparity(g, 2.5);
  for (const pl::Band band : {pl::Band::visible, pl::Band::infrared}) {
    const auto r = g.ranging(band);
    EXPECT_GE(d, r.grid.intrinsics().f * r.baseline_m / 2.5);
  }
}
