// Paper §3.3: texture coordinates per grid point and per-vertex colours sampled from an image.
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/texture.h"

#include <stb/stb_image_write.h>

#include <gtest/gtest.h>

namespace cloth_sim::core {
namespace {


/// Writes a 2 x 2 RGB PNG: red, green on the top row; blue, white below.
std::string writeTwoByTwoPng() {
  const std::string path = ::testing::TempDir() + "cloth_sim_test_texture.png";
  const unsigned char pixels[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
  EXPECT_NE(stbi_write_png(path.c_str(), 2, 2, 3, pixels, 2 * 3), 0);
  return path;
}

TEST(Texture, CornersOfTheClothGetTheCornerTexelsAndTheMiddleTheirBilinearMix) {
  const std::string png = writeTwoByTwoPng();
  const ClothGrid grid = buildClothGrid(3, 3, 1.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                        -Eigen::Vector3d::UnitZ());
  Eigen::Matrix3Xf colors;
  std::string error;
  ASSERT_TRUE(sceneVertexColors(png, grid.uv, &colors, &error)) << error;
  ASSERT_EQ(colors.cols(), 9);
  const auto expectColor = [&](int row, int col, const Eigen::Vector3f& rgb) {
    EXPECT_LT((colors.col(grid.index(row, col)) - rgb).norm(), 1e-6f) << "(" << row << ", " << col << ") is "
                                                                      << colors.col(grid.index(row, col)).transpose();
  };
  expectColor(0, 0, {1, 0, 0});  // uv (0, 0): top-left texel
  expectColor(0, 2, {0, 1, 0});  // uv (1, 0): top-right
  expectColor(2, 0, {0, 0, 1});  // uv (0, 1): bottom-left
  expectColor(2, 2, {1, 1, 1});  // uv (1, 1): bottom-right
  expectColor(0, 1, {0.5f, 0.5f, 0.0f});    // halfway between red and green
  expectColor(1, 1, {0.5f, 0.5f, 0.5f});    // the mean of all four
}

TEST(Texture, NoImageGivesTheBuiltInChecker) {
  // 33 x 33 particles: u = c / 32, so columns 1, 5, 9 sit in the middle of checker squares 0, 1, 2.
  const ClothGrid grid = buildClothGrid(33, 33, 1.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                        -Eigen::Vector3d::UnitZ());
  Eigen::Matrix3Xf colors;
  std::string error;
  ASSERT_TRUE(sceneVertexColors("", grid.uv, &colors, &error));
  EXPECT_EQ(colors, checkerColors(grid.uv));
  EXPECT_NE(colors.col(grid.index(1, 1)), colors.col(grid.index(1, 5))) << "neighbouring squares differ";
  EXPECT_EQ(colors.col(grid.index(1, 1)), colors.col(grid.index(1, 9))) << "squares two apart match";
  EXPECT_EQ(colors.col(grid.index(1, 1)), colors.col(grid.index(5, 5))) << "diagonal neighbours match";
}

TEST(Texture, UnreadableImageIsAnErrorNamingTheFile) {
  const ClothGrid grid = buildClothGrid(2, 2, 1.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                        -Eigen::Vector3d::UnitZ());
  Eigen::Matrix3Xf colors;
  std::string error;
  EXPECT_FALSE(sceneVertexColors("/nonexistent/cloth.png", grid.uv, &colors, &error));
  EXPECT_NE(error.find("/nonexistent/cloth.png"), std::string::npos) << error;
}

}  // namespace
}  // namespace cloth_sim::core
