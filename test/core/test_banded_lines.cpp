// The multigrid line smoother's kernels (banded_lines.h): eight lines factored and solved side by side
// solve each line's own system as a dense Cholesky does, and a line's factor and solution are the same
// bits in any lane, beside any lines (what keeps the cloth's bits independent of how lines are grouped).
#include "cloth_sim/core/banded_lines.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

namespace cloth_sim::core::banded_lines {
namespace {

/// Added to each diagonal beyond its row's off-diagonal sum: strictly dominant, so positive definite.
constexpr double kDominanceMargin = 0.5;
/// Solutions agree with the dense solve to this, relative (the lines' condition numbers are small).
constexpr double kSolveTolerance = 1e-12;
/// Line lengths in dofs (three per particle): shorter than the band, as long, and much longer.
constexpr int kLineDofs[] = {3, 9, 27};

/// A random symmetric positive definite matrix of `dofs` dofs banded like a line (half-width kLineBand).
Eigen::MatrixXd randomLine(int dofs, std::mt19937& random) {
  std::uniform_real_distribution<double> off_diagonal(-1.0, 1.0);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(dofs, dofs);
  for (int i = 0; i < dofs; ++i) {
    for (int k = 1; k <= kLineBand && k <= i; ++k) a(i, i - k) = a(i - k, i) = off_diagonal(random);
  }
  for (int i = 0; i < dofs; ++i) a(i, i) = a.row(i).cwiseAbs().sum() + kDominanceMargin;
  return a;
}

/// Writes matrix `a`'s lower band into `lane` of a group's band array.
void store(const Eigen::MatrixXd& a, int lane, std::vector<double>& band) {
  for (int i = 0; i < a.rows(); ++i) {
    for (int k = 0; k <= kLineBand && k <= i; ++k) band[static_cast<std::size_t>(entry(i, k, lane))] = a(i, i - k);
  }
}

Eigen::VectorXd randomVector(int dofs, std::mt19937& random) {
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  Eigen::VectorXd v(dofs);
  for (int i = 0; i < dofs; ++i) v[i] = value(random);
  return v;
}

TEST(BandedLines, EveryLaneSolvesItsOwnLineAsADenseCholeskyDoes) {
  std::mt19937 random(7);
  for (int dofs : kLineDofs) {
    std::vector<double> band(static_cast<std::size_t>(groupSize(dofs)), 0.0);
    std::vector<double> v(static_cast<std::size_t>(dofs) * kLanes);
    std::vector<Eigen::VectorXd> expected;
    for (int lane = 0; lane < kLanes; ++lane) {
      const Eigen::MatrixXd a = randomLine(dofs, random);
      const Eigen::VectorXd b = randomVector(dofs, random);
      store(a, lane, band);
      for (int i = 0; i < dofs; ++i) v[static_cast<std::size_t>(i) * kLanes + lane] = b[i];
      expected.push_back(a.llt().solve(b));
    }
    factor(dofs, band.data());
    solve(dofs, band.data(), v.data());
    for (int lane = 0; lane < kLanes; ++lane) {
      for (int i = 0; i < dofs; ++i) {
        EXPECT_NEAR(v[static_cast<std::size_t>(i) * kLanes + lane], expected[lane][i],
                    kSolveTolerance * expected[lane].lpNorm<Eigen::Infinity>())
            << dofs << " dofs, lane " << lane << ", dof " << i;
      }
    }
  }
}

TEST(BandedLines, ALineGivesTheSameBitsInAnyLaneBesideAnyLines) {
  std::mt19937 random(11);
  for (int dofs : kLineDofs) {
    const Eigen::MatrixXd line = randomLine(dofs, random);
    const Eigen::VectorXd b = randomVector(dofs, random);
    // First alone in lane 0 beside identity lines with zero right-hand sides (a grid's last group,
    // padded): those solve to zero.
    std::vector<double> alone(static_cast<std::size_t>(groupSize(dofs)), 0.0);
    std::vector<double> alone_v(static_cast<std::size_t>(dofs) * kLanes, 0.0);
    store(line, 0, alone);
    for (int lane = 1; lane < kLanes; ++lane) {
      for (int i = 0; i < dofs; ++i) alone[static_cast<std::size_t>(entry(i, 0, lane))] = 1.0;
    }
    for (int i = 0; i < dofs; ++i) alone_v[static_cast<std::size_t>(i) * kLanes] = b[i];
    factor(dofs, alone.data());
    solve(dofs, alone.data(), alone_v.data());
    for (int lane = 1; lane < kLanes; ++lane) {
      for (int i = 0; i < dofs; ++i) EXPECT_EQ(alone_v[static_cast<std::size_t>(i) * kLanes + lane], 0.0);
    }
    // Then in every other lane among random lines: the same factor and solution, bit for bit.
    for (int lane = 1; lane < kLanes; ++lane) {
      std::vector<double> band(static_cast<std::size_t>(groupSize(dofs)), 0.0);
      std::vector<double> v(static_cast<std::size_t>(dofs) * kLanes);
      for (int other = 0; other < kLanes; ++other) {
        const Eigen::VectorXd rhs = other == lane ? b : randomVector(dofs, random);
        store(other == lane ? line : randomLine(dofs, random), other, band);
        for (int i = 0; i < dofs; ++i) v[static_cast<std::size_t>(i) * kLanes + other] = rhs[i];
      }
      factor(dofs, band.data());
      solve(dofs, band.data(), v.data());
      for (int i = 0; i < dofs; ++i) {
        for (int k = 0; k <= kLineBand && k <= i; ++k) {
          EXPECT_EQ(band[static_cast<std::size_t>(entry(i, k, lane))], alone[static_cast<std::size_t>(entry(i, k, 0))])
              << dofs << " dofs, lane " << lane << ", factor entry (" << i << ", " << k << ")";
        }
        EXPECT_EQ(v[static_cast<std::size_t>(i) * kLanes + lane], alone_v[static_cast<std::size_t>(i) * kLanes])
            << dofs << " dofs, lane " << lane << ", dof " << i;
      }
    }
  }
}

}  // namespace
}  // namespace cloth_sim::core::banded_lines
