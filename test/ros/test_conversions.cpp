// Plain gtest (no roscore) of the message conversions that take input from other nodes.
#include "cloth_sim/ros/conversions.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>

namespace {

cloth_sim::ClothState gridState(std::uint32_t rows, std::uint32_t cols) {
  cloth_sim::ClothState message;
  message.rows = rows;
  message.cols = cols;
  message.positions.resize(static_cast<std::size_t>(rows) * cols);
  return message;
}

TEST(FromStateMessage, AcceptsAGridWithinItsLimitsWithEveryPosition) {
  Eigen::Matrix3Xd positions_m;
  std::string error;
  cloth_sim::ClothState message = gridState(3, 4);
  message.positions[5].z = 2.5;
  ASSERT_TRUE(cloth_sim::fromStateMessage(message, 512, &positions_m, &error)) << error;
  EXPECT_EQ(positions_m.cols(), 12);
  EXPECT_EQ(positions_m(2, 5), 2.5);
}

// Found by fuzz_conversions: max_side went through a uint32 cast, so a negative one accepted any grid.
TEST(FromStateMessage, AMaxSideBelowTwoRefusesEveryGrid) {
  Eigen::Matrix3Xd positions_m;
  std::string error;
  for (int max_side : {-1, 0, 1, std::numeric_limits<int>::min()}) {
    EXPECT_FALSE(cloth_sim::fromStateMessage(gridState(3, 3), max_side, &positions_m, &error)) << max_side;
    EXPECT_NE(error.find("each must be in [2, " + std::to_string(max_side) + "]"), std::string::npos) << error;
  }
}

TEST(FromStateMessage, RefusesANonFinitePosition) {
  Eigen::Matrix3Xd positions_m;
  std::string error;
  cloth_sim::ClothState message = gridState(2, 2);
  message.positions[3].y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(cloth_sim::fromStateMessage(message, 512, &positions_m, &error));
  EXPECT_EQ(error, "a position is not finite");
}

}  // namespace
