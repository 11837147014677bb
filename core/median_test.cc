#include "core/median.h"

#include <gtest/gtest.h>

namespace relit {
namespace {

TEST(Median, OddEvenAndOne) {
  EXPECT_EQ(Median(std::vector<double>{3, 1, 2}), 2);
  EXPECT_EQ(Median(std::vector<double>{4, 1, 3, 2}), 3);  // the upper middle, not 2.5
  EXPECT_EQ(Median(std::vector<int>{7}), 7);
  EXPECT_EQ(Median(std::vector<float>{5, 5, 1, 9, 9}), 5.0f);
}

TEST(Median, LeavesTheCallersListAlone) {
  const std::vector<double> values = {9, 8, 7, 6, 5};
  EXPECT_EQ(Median(values), 7);
  EXPECT_EQ(values, (std::vector<double>{9, 8, 7, 6, 5}));
}

TEST(Median, OfNothingIsAnError) { EXPECT_THROW(Median(std::vector<double>{}), Error); }

}  // namespace
}  // namespace relit
