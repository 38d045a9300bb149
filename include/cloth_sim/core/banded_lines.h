// The multigrid line smoother's kernels (multigrid.cpp): banded Cholesky factors and solves of grid
// lines, several side by side. A line is the three dofs of every particle along one grid row or column;
// its own couplings reach GridBlockMatrix::kMaxReach particles along it, so its matrix is banded.
#pragma once

#include "cloth_sim/core/grid_matrix.h"

#include <cstddef>

namespace cloth_sim::core::banded_lines {

/// Half-bandwidth, in dofs, of one line's own couplings: a particle reaches kMaxReach particles along it.
inline constexpr int kLineBand = 3 * GridBlockMatrix::kMaxReach + 2;
/// Entries stored per dof: the diagonal and the kLineBand below it.
inline constexpr int kBandWidth = kLineBand + 1;
/// Lines factored and solved side by side, one per SIMD lane. A line's solve is a chain in which each
/// dof waits for the one before it, so one line at a time left the processor waiting on that chain;
/// eight lines run the same chain together (one AVX-512 vector, two AVX2 or four SSE2 ones). Lanes past
/// the last line of a grid hold identity lines.
inline constexpr int kLanes = 8;

/// Where entry (dof, k) of `lane` lies in a group's array: band(dof, k) = A(dof, dof - k), the lanes of
/// one entry side by side.
inline std::ptrdiff_t entry(int dof, int k, int lane) {
  return (static_cast<std::ptrdiff_t>(dof) * kBandWidth + k) * kLanes + lane;
}

/// Doubles in a group's band array: kLanes lines of `dofs` dofs.
inline std::ptrdiff_t groupSize(int dofs) { return entry(dofs, 0, 0); }

/// Groups of kLanes lines that cover `lines`.
inline int laneGroups(int lines) { return (lines + kLanes - 1) / kLanes; }

/// In place, for every lane of a group of `dofs`-dof lines: band(i, k) = A(i, i - k) becomes the
/// Cholesky factor's L(i, i - k), except on the diagonal, which holds 1 / L(i, i) (the solves then
/// multiply: a division's latency would sit on their critical path). A line that is not positive
/// definite on a diagonal (rounding) gets 1 there. Every lane does the same operations in the same
/// order as a line on its own would: a line's factor is the same bits in any lane, beside any lines.
void factor(int dofs, double* band);

/// Solves L L^T y = v in place for every lane (v's entry (dof i, lane) at i * kLanes + lane), with the
/// factor of factor(). The same bits for a line in any lane, beside any lines.
void solve(int dofs, const double* band, double* v);

}  // namespace cloth_sim::core::banded_lines
