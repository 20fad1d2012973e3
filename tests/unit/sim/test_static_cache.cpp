// The simulated rig's static scene cache (sim::StaticCache): a rig built from the cache renders
// the same bytes as one that traced the scene, and a cache file that is foreign (another key),
// truncated or not a cache at all is never used: the rig traces the scene and says why.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>

#include "thermovis/runtime/rig_io.hpp"
#include "thermovis/runtime/scene_io.hpp"
#include "thermovis/sim/simulated_rig.hpp"
#include "thermovis/test/data.hpp"

namespace {

using thermovis::sim::FrameSet;
using thermovis::sim::SimulatedRig;
using thermovis::sim::StaticCache;

thermovis::camera::Rig paper_rig() {
  return thermovis::runtime::load_rig(thermovis::test::source_root() / "deploy/rigs/paper.yaml");
}

// An open plain: cheap to trace, for the cases where the cache must not be used.
thermovis::sim::Scene flat_scene() {
  return thermovis::runtime::parse_scene(R"(name: flat
visible: {illuminance_lux: 5000, sky_colour_rgb: [0.6, 0.7, 0.8]}
infrared: {ambient_c: 10, sky_c: -10}
)",
                                         "flat");
}

bool same_bytes(const FrameSet& a, const FrameSet& b) {
  for (std::size_t i = 0; i < a.images.size(); ++i) {
    if (a.images[i].size() != b.images[i].size() || a.images[i].type() != b.images[i].type())
      return false;
    cv::Mat diff;
    cv::compare(a.images[i], b.images[i], diff, cv::CMP_NE);
    if (cv::countNonZero(diff.reshape(1)) != 0) return false;
  }
  return true;
}

TEST(StaticCache, ARigFromTheCacheRendersTheSameBytes) {
  const auto dir = thermovis::test::temp_dir("static_cache");
  const StaticCache cache{dir / "paper.bin", "paper rig, paper scene"};
  const auto scene =
      thermovis::runtime::load_scene(thermovis::test::source_root() / "deploy/scenes/paper.yaml");
  const SimulatedRig traced(paper_rig(), scene, 5, {}, cache);
  EXPECT_FALSE(traced.static_setup().loaded);
  ASSERT_TRUE(std::filesystem::exists(cache.file)) << traced.static_setup().note;
  const SimulatedRig loaded(paper_rig(), scene, 5, {}, cache);
  EXPECT_TRUE(loaded.static_setup().loaded) << loaded.static_setup().note;
  EXPECT_EQ(loaded.static_setup().note, "");
  // Frames with the people and cars of the scene moving over the static background.
  for (const std::int64_t frame : {0, 37}) {
    FrameSet a = traced.allocate(), b = loaded.allocate();
    traced.render(frame, a);
    loaded.render(frame, b);
    EXPECT_TRUE(same_bytes(a, b)) << "frame " << frame;
  }
  // Another seed draws other noise: the file is not used.
  const SimulatedRig other_seed(paper_rig(), scene, 6, {}, cache);
  EXPECT_FALSE(other_seed.static_setup().loaded);
  EXPECT_NE(other_seed.static_setup().note.find("for another rig, scene, seed or build"),
            std::string::npos)
      << other_seed.static_setup().note;
  FrameSet a = traced.allocate(), b = other_seed.allocate();
  traced.render(0, a);
  other_seed.render(0, b);
  EXPECT_FALSE(same_bytes(a, b));
  std::filesystem::remove_all(dir);
}

TEST(StaticCache, AForeignTruncatedOrGarbageFileIsTracedAgainAndNamed) {
  const auto dir = thermovis::test::temp_dir("static_cache_bad");
  const StaticCache cache{dir / "flat.bin", "flat"};
  const SimulatedRig first(paper_rig(), flat_scene(), 1, {}, cache);
  EXPECT_NE(first.static_setup().note.find("no cache file"), std::string::npos)
      << first.static_setup().note;
  FrameSet reference = first.allocate();
  first.render(2, reference);
  const auto size = std::filesystem::file_size(cache.file);
  ASSERT_GT(size, 10'000'000u);

  const SimulatedRig foreign(paper_rig(), flat_scene(), 1, {}, StaticCache{cache.file, "other"});
  EXPECT_FALSE(foreign.static_setup().loaded);
  EXPECT_NE(foreign.static_setup().note.find("is for another rig, scene, seed or build"),
            std::string::npos)
      << foreign.static_setup().note;

  // The foreign rig wrote its own key; now the header is overwritten.
  {
    std::fstream file(cache.file, std::ios::in | std::ios::out | std::ios::binary);
    file.write("garbage!", 8);
  }
  const SimulatedRig garbage(paper_rig(), flat_scene(), 1, {}, cache);
  EXPECT_FALSE(garbage.static_setup().loaded);
  EXPECT_NE(garbage.static_setup().note.find("is not a static scene cache"), std::string::npos)
      << garbage.static_setup().note;

  // Traced again and rewritten whole: the next rig reads it; then cut short.
  std::filesystem::resize_file(cache.file, size - 1000);
  const SimulatedRig truncated(paper_rig(), flat_scene(), 1, {}, cache);
  EXPECT_FALSE(truncated.static_setup().loaded);
  EXPECT_NE(truncated.static_setup().note.find("is truncated"), std::string::npos)
      << truncated.static_setup().note;
  const SimulatedRig again(paper_rig(), flat_scene(), 1, {}, cache);
  EXPECT_TRUE(again.static_setup().loaded) << again.static_setup().note;
  FrameSet rendered = again.allocate();
  again.render(2, rendered);
  EXPECT_TRUE(same_bytes(reference, rendered));
  std::filesystem::remove_all(dir);
}

TEST(StaticCache, AnUnwritableFolderIsNotAnError) {
  const SimulatedRig rig(paper_rig(), flat_scene(), 1, {},
                         StaticCache{"/proc/no-such-folder/flat.bin", "flat"});
  EXPECT_FALSE(rig.static_setup().loaded);
  EXPECT_NE(rig.static_setup().note.find("cannot write"), std::string::npos)
      << rig.static_setup().note;
}

}  // namespace
