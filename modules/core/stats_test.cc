// Summary statistics against hand-computed values (NumPy's percentile convention).
#include "core/stats.h"

#include <gtest/gtest.h>

namespace relight {
namespace {

TEST(Stats, MeanMedianAndInterpolatedPercentiles) {
  EXPECT_DOUBLE_EQ(Mean({1, 2, 6}), 3.0);
  EXPECT_DOUBLE_EQ(Mean({}), 0.0);
  EXPECT_DOUBLE_EQ(Median({5, 1, 3}), 3.0);
  EXPECT_DOUBLE_EQ(Median({4, 1, 3, 2}), 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(Median({}), 0.0);
  std::vector<double> v = {10, 0, 40, 20, 30};  // sorted: 0 10 20 30 40, ranks 0..4
  EXPECT_DOUBLE_EQ(Percentile(&v, 0), 0.0);
  EXPECT_DOUBLE_EQ(Percentile(&v, 100), 40.0);
  EXPECT_DOUBLE_EQ(Percentile(&v, 90), 36.0);   // rank 3.6
  EXPECT_DOUBLE_EQ(Percentile(&v, 12.5), 5.0);  // rank 0.5
  EXPECT_DOUBLE_EQ(Percentile(&v, 150), 40.0);  // clamped
  EXPECT_DOUBLE_EQ(PercentileOf({7}, 37), 7.0);
}

}  // namespace
}  // namespace relight
