#include "protocol/geometry.h"

#include <gtest/gtest.h>

namespace loam {
namespace {

TEST(Geometry, FloorDivisionRoundsTowardNegativeInfinity) {
  EXPECT_EQ(floor_div(-1, 256), -1);
  EXPECT_EQ(floor_div(-256, 256), -1);
  EXPECT_EQ(floor_div(-257, 256), -2);
  EXPECT_EQ(floor_div(255, 256), 0);
  EXPECT_EQ(floor_mod(-1, 256), 255);
  EXPECT_EQ(ceil_div(-1, 256), 0);
  EXPECT_EQ(ceil_div(257, 256), 2);
}

}  // namespace
}  // namespace loam
