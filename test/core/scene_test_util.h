// Helpers shared by the core tests: loading the built-in scenes and measuring a cloth's shape.
#pragma once

#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace cloth_sim::core {
namespace test {

inline std::string scenesDir() { return std::string(CLOTH_SIM_SOURCE_DIR) + "/config/scenes"; }

/// The options of a built-in scene; fails the test (and returns the defaults) if it does not load.
inline SceneOptions loadBuiltinScene(const std::string& name) {
  SceneOptions options;
  std::vector<std::string> errors;
  const bool loaded = loadSceneFile(resolveScenePath(name, scenesDir()), &options, &errors);
  EXPECT_TRUE(loaded) << name << ": " << (errors.empty() ? "" : errors.front());
  return options;
}

/// A built-in material preset; fails the test (and returns an empty material) if there is none.
inline MaterialOptions preset(const std::string& name) {
  MaterialOptions material;
  EXPECT_TRUE(findMaterialPreset(name, &material)) << name;
  return material;
}

/// The rest grid jiggled by up to 30 % of a spacing, with random velocities in [-1, 1] m/s: every spring
/// stretched, compressed, skewed and moving, so every term of a linearisation is exercised.
inline void perturb(const ClothGrid& grid, std::uint32_t seed, Eigen::Matrix3Xd* positions,
                    Eigen::Matrix3Xd* velocities) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double spacing = (grid.rest_positions_m.col(1) - grid.rest_positions_m.col(0)).norm();
  *positions = grid.rest_positions_m;
  velocities->resize(3, grid.particleCount());
  for (Eigen::Index i = 0; i < positions->size(); ++i) {
    positions->data()[i] += 0.3 * spacing * unit(random);
    velocities->data()[i] = unit(random);
  }
}

/// The explicit method and substeps the closed-form tests were written for (the paper's symplectic Euler
/// at 40 substeps): implicit Euler damps by design, so closed forms of undamped motion do not apply to it.
inline SceneOptions withSymplecticEuler(SceneOptions options) {
  options.integrator = IntegratorKind::kSymplecticEuler;
  options.substeps = 40;
  return options;
}

/// A rows x cols cloth floating free: the default springs, nothing pinned, no gravity; symplectic Euler.
inline SceneOptions freeCloth(int rows, int cols) {
  SceneOptions options = withSymplecticEuler(SceneOptions());
  options.rows = rows;
  options.cols = cols;
  options.pins.clear();
  options.gravity_m_per_s2.setZero();
  return options;
}

/// Mean position of a set of particles, world frame, m.
inline Eigen::Vector3d meanOf(const Eigen::Matrix3Xd& positions_m, const std::vector<int>& particles) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i : particles) sum += positions_m.col(i);
  return sum / static_cast<double>(particles.size());
}

/// Indices of one grid row or column.
inline std::vector<int> rowOf(const ClothGrid& grid, int row) {
  std::vector<int> out;
  for (int c = 0; c < grid.cols; ++c) out.push_back(grid.index(row, c));
  return out;
}
inline std::vector<int> columnOf(const ClothGrid& grid, int col) {
  std::vector<int> out;
  for (int r = 0; r < grid.rows; ++r) out.push_back(grid.index(r, col));
  return out;
}

}  // namespace test
}  // namespace cloth_sim::core
