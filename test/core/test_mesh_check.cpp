// The mesh checker of issue 15 on hand-made sheets: a flat sheet and a sheet folded with a gap have no
// crossing triangle pairs, a sheet whose half weaves through the other half has some, two separate sheets
// crossing at an angle have exactly the pairs along their line of intersection, a crumpled sheet has the
// pairs a test of every pair finds (each once, in order), and the segment test against closed cases.
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/mesh_check.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

namespace cloth_sim::core {
namespace {

/// A rows x cols flat 1 m square in the x-y plane (z = 0), the grid's own triangles.
ClothGrid flatSheet(int rows, int cols) {
  return buildClothGrid(rows, cols, 1.0, 1.0, Eigen::Vector3d(-0.5, -0.5, 0.0), Eigen::Vector3d::UnitX(),
                        Eigen::Vector3d::UnitY());
}

TEST(MeshCheck, ASegmentCrossesATriangleOnlyThroughItsInside) {
  const Eigen::Vector3d p(0.0, 0.0, 0.0), q(1.0, 0.0, 0.0), r(0.0, 1.0, 0.0);
  EXPECT_TRUE(segmentCrossesTriangle({0.2, 0.2, -1.0}, {0.2, 0.2, 1.0}, p, q, r));
  EXPECT_FALSE(segmentCrossesTriangle({0.2, 0.2, 0.5}, {0.2, 0.2, 1.0}, p, q, r)) << "stops short of the plane";
  EXPECT_FALSE(segmentCrossesTriangle({0.8, 0.8, -1.0}, {0.8, 0.8, 1.0}, p, q, r)) << "outside the triangle";
  EXPECT_FALSE(segmentCrossesTriangle({0.1, 0.1, 0.0}, {0.5, 0.2, 0.0}, p, q, r)) << "in the plane: touching";
  EXPECT_TRUE(segmentCrossesTriangle({0.1, 0.1, 1.0}, {0.3, 0.1, -1.0}, p, q, r)) << "slanted through";
}

TEST(MeshCheck, AFlatSheetHasNoCrossingPairs) {
  const ClothGrid grid = flatSheet(24, 24);
  EXPECT_TRUE(crossingTrianglePairs(grid.triangles, grid.rest_positions_m).empty());
}

/// The sheet folded in half along its middle row: the far half mirrored above the near one, `gap` m up.
Eigen::Matrix3Xd folded(const ClothGrid& grid, double gap_m) {
  Eigen::Matrix3Xd x = grid.rest_positions_m;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    if (x(1, i) > 0.0) {
      x(1, i) = -x(1, i);
      x(2, i) = gap_m;
    }
  }
  return x;
}

TEST(MeshCheck, ASheetFoldedWithAGapHasNoCrossingPairs) {
  // 25 rows: the middle row (y = 0) is the fold line, every other row lands on a mirror row.
  const ClothGrid grid = flatSheet(25, 25);
  EXPECT_TRUE(crossingTrianglePairs(grid.triangles, folded(grid, 0.01)).empty());
}

TEST(MeshCheck, AHalfWeavingThroughTheOtherHalfCrosses) {
  const ClothGrid grid = flatSheet(25, 25);
  Eigen::Matrix3Xd x = folded(grid, 0.01);
  // Push a band of the upper half's columns down through the lower half: it weaves under and over.
  int moved = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    if (x(2, i) > 0.0 && std::abs(x(0, i)) < 0.15) {
      x(2, i) = -0.02;
      ++moved;
    }
  }
  ASSERT_GT(moved, 0);
  EXPECT_GT(crossingTrianglePairs(grid.triangles, x).size(), 0u);
}

TEST(MeshCheck, TwoSheetsCrossingAtAnAngleCrossAlongTheirIntersectionOnly) {
  // Two separate 10x10 sheets: the second turned 30 degrees about x, so it cuts the first along y = 0.
  const ClothGrid grid = flatSheet(10, 10);
  const int n = grid.particleCount();
  std::vector<int> triangles = grid.triangles;
  for (const int index : grid.triangles) triangles.push_back(index + n);
  Eigen::Matrix3Xd x(3, 2 * n);
  x.leftCols(n) = grid.rest_positions_m;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitX()).toRotationMatrix();
  x.rightCols(n) = turn * grid.rest_positions_m;
  const auto pairs = crossingTrianglePairs(triangles, x);
  ASSERT_FALSE(pairs.empty());
  const int per_sheet = static_cast<int>(grid.triangles.size() / 3);
  for (const auto& [a, b] : pairs) {
    EXPECT_LT(a, per_sheet) << "a pair within one sheet";
    EXPECT_GE(b, per_sheet) << "a pair within one sheet";
    EXPECT_LT(a, b);
  }
  // Lifting the second sheet 2 m away: none.
  x.rightCols(n).row(2).array() += 2.0;
  EXPECT_TRUE(crossingTrianglePairs(triangles, x).empty());
}

TEST(MeshCheck, ACrumpledSheetHasExactlyThePairsThatTestingEveryPairFinds) {
  // Random crumples pass triangles through each other at every angle, and put many triangles' boxes over
  // several cells: the grid must find each crossing pair once, and miss none.
  const ClothGrid grid = flatSheet(14, 14);
  const int count = static_cast<int>(grid.triangles.size() / 3);
  std::mt19937 random(7);
  std::normal_distribution<double> jitter(0.0, 0.04);  // m, on a 1/13 m spacing
  for (int trial = 0; trial < 3; ++trial) {
    Eigen::Matrix3Xd x = grid.rest_positions_m;
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      x.col(i) += Eigen::Vector3d(jitter(random), jitter(random), jitter(random));
    }
    std::vector<std::pair<int, int>> every;
    for (int a = 0; a < count; ++a) {
      for (int b = a + 1; b < count; ++b) {
        const int* ta = &grid.triangles[static_cast<std::size_t>(3 * a)];
        const int* tb = &grid.triangles[static_cast<std::size_t>(3 * b)];
        bool shared = false;
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) shared = shared || ta[i] == tb[j];
        }
        if (shared) continue;
        bool cross = false;
        for (int e = 0; e < 3 && !cross; ++e) {
          cross = segmentCrossesTriangle(x.col(ta[e]), x.col(ta[(e + 1) % 3]), x.col(tb[0]), x.col(tb[1]),
                                         x.col(tb[2])) ||
                  segmentCrossesTriangle(x.col(tb[e]), x.col(tb[(e + 1) % 3]), x.col(ta[0]), x.col(ta[1]),
                                         x.col(ta[2]));
        }
        if (cross) every.emplace_back(a, b);
      }
    }
    ASSERT_GT(every.size(), 10u) << "trial " << trial << ": crumpled too little to test anything";
    EXPECT_EQ(crossingTrianglePairs(grid.triangles, x), every) << "trial " << trial;
  }
}

}  // namespace
}  // namespace cloth_sim::core
