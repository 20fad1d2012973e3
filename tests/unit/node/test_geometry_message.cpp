// thermovis/geometry's message: what rectify-fuse publishes and every other service builds its
// stages on, through the message and back.
#include <gtest/gtest.h>

#include <string>

#include "thermovis/node/frame_codec.hpp"
#include "thermovis/node/geometry_topic.hpp"
#include "thermovis/runtime/rig_io.hpp"

namespace pl = thermovis::pipeline;
namespace tn = thermovis::node;

namespace {

std::string error_of(const thermovis::GridGeometry& m) {
  try {
    tn::from_message(m);
    return "";
  } catch (const tn::FrameError& e) {
    return e.what();
  }
}

}  // namespace

TEST(GeometryMessage, TheInfraredReductionCrossesAndIsChecked) {
  const auto rig = thermovis::runtime::load_rig(thermovis::runtime::default_rig_path());
  for (const double scale : {0.5, 1.0}) {
    pl::GridOptions options;
    options.scale = scale;
    const pl::PipelineGeometry g = pl::make_geometry(rig, options);
    const pl::PipelineGeometry back = tn::from_message(tn::to_message(g));
    EXPECT_EQ(back.id(), g.id());
    EXPECT_EQ(back.infrared_reduction, g.infrared_reduction);
    EXPECT_EQ(back.image_size(pl::Band::infrared), g.image_size(pl::Band::infrared));
  }
  pl::GridOptions full;
  full.scale = 1.0;
  thermovis::GridGeometry m = tn::to_message(pl::make_geometry(rig, full));
  ASSERT_EQ(m.infrared_reduction(), 2u);
  // A reduction the digest does not hold, and one no stage can work with.
  m.infrared_reduction(1);
  EXPECT_NE(error_of(m).find("not the digest"), std::string::npos) << error_of(m);
  m.infrared_reduction(0);
  EXPECT_NE(error_of(m).find("infrared reduction"), std::string::npos) << error_of(m);
  m.infrared_reduction(4000000000u);
  EXPECT_NE(error_of(m).find("infrared reduction"), std::string::npos) << error_of(m);
}
