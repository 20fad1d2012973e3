// metrics::percentile: nearest rank on small lists whose answers can be counted by hand.
#include <gtest/gtest.h>

#include <vector>

#include "thermovis/metrics/percentile.hpp"

namespace {

using thermovis::metrics::percentile;

TEST(Percentile, NearestRankOfTenValues) {
  // Out of order on purpose: the function sorts its own copy.
  const std::vector<double> ms{7, 3, 10, 1, 9, 2, 8, 4, 6, 5};
  EXPECT_DOUBLE_EQ(percentile(ms, 0), 1);
  EXPECT_DOUBLE_EQ(percentile(ms, 10), 1);   // rank ceil(1.0) = 1
  EXPECT_DOUBLE_EQ(percentile(ms, 11), 2);   // rank ceil(1.1) = 2
  EXPECT_DOUBLE_EQ(percentile(ms, 50), 5);   // rank 5
  EXPECT_DOUBLE_EQ(percentile(ms, 95), 10);  // rank ceil(9.5) = 10
  EXPECT_DOUBLE_EQ(percentile(ms, 99), 10);
  EXPECT_DOUBLE_EQ(percentile(ms, 100), 10);
}

TEST(Percentile, RepeatedValuesAndOneValue) {
  EXPECT_DOUBLE_EQ(percentile({4, 4, 4, 1}, 50), 4);  // rank 2 of 1, 4, 4, 4
  EXPECT_DOUBLE_EQ(percentile({4, 4, 4, 1}, 25), 1);
  EXPECT_DOUBLE_EQ(percentile({2.5}, 0), 2.5);
  EXPECT_DOUBLE_EQ(percentile({2.5}, 99), 2.5);
}

TEST(Percentile, EmptyListGivesZero) { EXPECT_DOUBLE_EQ(percentile({}, 50), 0.0); }

}  // namespace
