// `thermovis bench obstacles` as a user runs it: a few captures of the simulated street and of
// its empty road, as one JSON object (recall, few false obstacles: none in 50 frames),
// and bad arguments named.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "thermovis/test/data.hpp"

using thermovis::test::run_thermovis;

TEST(ObstacleCli, BenchFindsTheStreetsTargetsAndFewOnTheEmptyRoad) {
  const auto r = run_thermovis("bench obstacles --frames 4 --empty-frames 4 --band visible --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(j.at("scene"), "street");
  EXPECT_EQ(j.at("pairs_without_ground"), 0) << j;
  EXPECT_GE(j.at("recall_pct").get<double>(), 80.0) << j;
  EXPECT_LE(j.at("false_obstacles_per_100_frames").get<double>(), 25.0) << j;
  // Per distance: the near targets found within 5 % at the median.
  const auto& near = j.at("per_distance").at(0);
  EXPECT_EQ(near.at("distance_m"), "0-10");
  EXPECT_GT(near.at("found").get<int>(), 0) << j;
  EXPECT_LT(near.at("median_rel_error_pct").get<double>(), 5.0) << j;
  // The standing person (15 m, still) is found in every capture.
  bool standing = false;
  for (const auto& t : j.at("targets")) {
    if (t.at("id") != "standing") continue;
    standing = true;
    EXPECT_EQ(t.at("found"), t.at("in_view")) << t;
    EXPECT_NEAR(t.at("truth_distance_m").get<double>(), 15.0, 0.5) << t;
  }
  EXPECT_TRUE(standing) << j;
}

// At night (0.02 lux) the visible pair sees noise only: the infrared pair alone, registered
// onto the visible grid with its right eye off the grid's axis, finds the near objects (boxes,
// a parked car, a pole, 5-15 m) on its own ground, and nothing on the empty dark road.
TEST(ObstacleCli, TheInfraredPairAloneFindsTheNearObjectsAtNight) {
  const auto r = run_thermovis(
      "bench obstacles --scene obstacles_night --band infrared --frames 4 --empty-frames 10 "
      "--json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output.substr(r.output.find('{')));
  EXPECT_GE(j.at("recall_pct").get<double>(), 30.0) << j;
  EXPECT_EQ(j.at("false_obstacles_per_100_frames").get<double>(), 0.0) << j;
  const auto& near = j.at("per_distance").at(0);
  EXPECT_EQ(near.at("distance_m"), "0-10");
  EXPECT_EQ(near.at("found"), near.at("truths")) << j;
  EXPECT_LT(near.at("median_rel_error_pct").get<double>(), 5.0) << j;
  for (const auto& t : j.at("targets")) {
    if (t.at("id") == "box_5" || t.at("id") == "parked_car") {
      EXPECT_EQ(t.at("found"), t.at("in_view")) << t;
    }
  }
}

TEST(ObstacleCli, BadArgumentsAreNamed) {
  const auto band = run_thermovis("bench obstacles --band ultraviolet");
  EXPECT_NE(band.exit_code, 0);
  EXPECT_NE(band.output.find("--band"), std::string::npos) << band.output;
  const auto method = run_thermovis("bench obstacles --method surf --frames 1 --empty-frames 0");
  EXPECT_NE(method.exit_code, 0);
  EXPECT_NE(method.output.find("surf"), std::string::npos) << method.output;
}
