#include "cloth_sim/core/banded_lines.h"

#include "vector_clones.h"

#include <cmath>

namespace cloth_sim::core::banded_lines {

namespace {

/// The sum of row[k * row_step] * v[-k * v_step] over k = 2..kLineBand as a tree: none of it waits for
/// v[-v_step], which the previous dof has just computed, so only one product and two subtractions per dof
/// stay on the solve's critical path (a left-to-right sum put all eight there). A fixed order: the same
/// bits every time.
static_assert(kLineBand == 8, "farSum is written out for a band of 8");
inline double farSum(const double* row, std::ptrdiff_t row_step, const double* v, std::ptrdiff_t v_step) {
  return ((row[8 * row_step] * v[-8 * v_step] + row[7 * row_step] * v[-7 * v_step]) +
          (row[6 * row_step] * v[-6 * v_step] + row[5 * row_step] * v[-5 * v_step])) +
         ((row[4 * row_step] * v[-4 * v_step] + row[3 * row_step] * v[-3 * v_step]) +
          row[2 * row_step] * v[-2 * v_step]);
}

}  // namespace

CLOTH_SIM_VECTOR_CLONES void factor(int dofs, double* __restrict band) {
  // Right-looking: once column j is final it updates the band below it. Every update of one column is
  // independent of the others, so none waits for the previous one (a left-looking dot product put a
  // chain of eight dependent subtractions on every entry).
  for (int j = 0; j < dofs; ++j) {
    double* row_j = band + entry(j, 0, 0);
    for (int lane = 0; lane < kLanes; ++lane) {
      // Positive for a positive definite line (every line of M + PSD terms is); guarded against rounding.
      const double diagonal = row_j[lane];
      row_j[lane] = diagonal > 0.0 ? 1.0 / std::sqrt(diagonal) : 1.0;
    }
    const int last = j + kLineBand < dofs ? j + kLineBand : dofs - 1;
    double column[kBandWidth * kLanes];
    for (int i = j + 1; i <= last; ++i) {
      double* below = band + entry(i, i - j, 0);  // L(i, j)
      for (int lane = 0; lane < kLanes; ++lane) {
        below[lane] *= row_j[lane];
        column[(i - j) * kLanes + lane] = below[lane];
      }
    }
    for (int i = j + 1; i <= last; ++i) {
      double* row_i = band + entry(i, 0, 0);
      const double* l_ij = column + (i - j) * kLanes;
      for (int m = j + 1; m <= i; ++m) {  // A(i, m) -= L(i, j) L(m, j)
        double* target = row_i + (i - m) * kLanes;
        const double* l_mj = column + (m - j) * kLanes;
        for (int lane = 0; lane < kLanes; ++lane) target[lane] -= l_ij[lane] * l_mj[lane];
      }
    }
  }
}

CLOTH_SIM_VECTOR_CLONES void solve(int dofs, const double* __restrict band, double* __restrict v) {
  constexpr std::ptrdiff_t kRowStep = kLanes;  // band(i, k) to band(i, k + 1)
  constexpr std::ptrdiff_t kColumnStep = (kBandWidth + 1) * kLanes;  // band(i, 0) to band(i + 1, 1), L(i + 1, i)
  double value[kLanes];
  for (int i = 0; i < dofs; ++i) {
    const double* row = band + entry(i, 0, 0);
    double* v_i = v + static_cast<std::ptrdiff_t>(i) * kLanes;
    if (i >= kLineBand) {
      for (int lane = 0; lane < kLanes; ++lane) {
        v_i[lane] = (v_i[lane] - farSum(row + lane, kRowStep, v_i + lane, kLanes) -
                     row[kRowStep + lane] * v_i[lane - kLanes]) *
                    row[lane];
      }
      continue;
    }
    for (int lane = 0; lane < kLanes; ++lane) value[lane] = v_i[lane];
    for (int k = i; k >= 1; --k) {
      for (int lane = 0; lane < kLanes; ++lane) value[lane] -= row[k * kRowStep + lane] * v_i[lane - k * kLanes];
    }
    for (int lane = 0; lane < kLanes; ++lane) v_i[lane] = value[lane] * row[lane];
  }
  // L^T: row i of L^T holds L(i + k, i), band(i + k, k): kColumnStep apart from band(i, 0).
  for (int i = dofs - 1; i >= 0; --i) {
    const int reach = dofs - 1 - i < kLineBand ? dofs - 1 - i : kLineBand;
    const double* column = band + entry(i, 0, 0);
    double* v_i = v + static_cast<std::ptrdiff_t>(i) * kLanes;
    if (reach == kLineBand) {
      // farSum reads row[k * row_step] * v[-k * v_step]: with v_step -kLanes it reads v's dof i + k.
      for (int lane = 0; lane < kLanes; ++lane) {
        v_i[lane] = (v_i[lane] - farSum(column + lane, kColumnStep, v_i + lane, -kLanes) -
                     column[kColumnStep + lane] * v_i[lane + kLanes]) *
                    column[lane];
      }
      continue;
    }
    for (int lane = 0; lane < kLanes; ++lane) value[lane] = v_i[lane];
    for (int k = reach; k >= 1; --k) {
      for (int lane = 0; lane < kLanes; ++lane) value[lane] -= column[k * kColumnStep + lane] * v_i[lane + k * kLanes];
    }
    for (int lane = 0; lane < kLanes; ++lane) v_i[lane] = value[lane] * column[lane];
  }
}

}  // namespace cloth_sim::core::banded_lines
