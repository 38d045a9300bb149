#include "cloth_sim/core/multigrid.h"

#include "cloth_sim/core/banded_lines.h"

#include "parallel.h"

#include <algorithm>
#include <cmath>

namespace cloth_sim::core {

namespace {

/// Sides of this many particles or fewer are not coarsened.
constexpr int kSmallestCoarsenedSide = 3;

/// Index of {dr, dc} in GridBlockMatrix::fullStencil().
inline int fullStencilIndex(int dr, int dc) {
  constexpr int width = 2 * GridBlockMatrix::kMaxReach + 1;
  return (dr + GridBlockMatrix::kMaxReach) * width + dc + GridBlockMatrix::kMaxReach;
}

/// Entry (a, b) of a symmetric block stored as xx, yy, zz, xy, xz, yz.
inline double blockEntry(const double* block, int a, int b) {
  static constexpr int kIndex[3][3] = {{0, 3, 4}, {3, 1, 5}, {4, 5, 2}};
  return block[kIndex[a][b]];
}

using banded_lines::entry;
using banded_lines::groupSize;
using banded_lines::kLanes;
using banded_lines::laneGroups;

/// Particle index of position t along line `line` of a rows x cols grid (a row's or a column's).
inline int lineParticle(bool rows, int cols, int line, int t) { return rows ? line * cols + t : t * cols + line; }

}  // namespace

void MultigridPreconditioner::factorLines(Level& level, bool rows) const {
  const GridBlockMatrix& a = level.matrix;
  const int lines = rows ? a.rows() : a.cols();
  const int length = rows ? a.cols() : a.rows();
  const int dofs = 3 * length;
  const int groups = laneGroups(lines);
  const std::ptrdiff_t group_size = groupSize(dofs);
  std::vector<double>& factors = rows ? level.row_factors : level.col_factors;
  factors.assign(static_cast<std::size_t>(groups * group_size), 0.0);
  int along[GridBlockMatrix::kMaxReach + 1];
  for (int d = 0; d <= GridBlockMatrix::kMaxReach; ++d) along[d] = rows ? a.offsetIndex(0, -d) : a.offsetIndex(-d, 0);
  const int n = a.particles();
  // The bands are filled walking the particles in memory order (a column's particles lie a whole grid
  // row of blocks apart: reading them column by column missed the cache on nearly every block), then
  // factored a group of lines at a time. The fill only copies, so its order does not change any bits.
#pragma omp parallel for schedule(static) num_threads(threads_) if (runsInParallel(n, threads_))
  for (int r = 0; r < a.rows(); ++r) {
    for (int col = 0; col < a.cols(); ++col) {
      const int p = r * a.cols() + col;
      const int line = rows ? r : col;
      const int t = rows ? col : r;
      double* band = factors.data() + (line / kLanes) * group_size;  // this line's group
      const int lane = line % kLanes;
      // The band starts zero, so only the nonzero entries are written.
      if (level.free[p] == 0.0) {  // a fixed dof: decoupled, identity
        for (int i = 0; i < 3; ++i) band[entry(3 * t + i, 0, lane)] = 1.0;
        continue;
      }
      for (int d = 0; d <= GridBlockMatrix::kMaxReach && d <= t; ++d) {
        if (along[d] < 0) continue;
        const int q = rows ? p - d : p - d * a.cols();
        if (level.free[q] == 0.0) continue;
        const double* block = a.block(p, along[d]);
        for (int i = 0; i < 3; ++i) {
          // A(3t + i, 3(t - d) + j) sits k = 3d + i - j below the diagonal; the upper triangle of the
          // diagonal block (j > i when d = 0) is not stored.
          const int last_j = d == 0 ? i : 2;
          for (int j = 0; j <= last_j; ++j) band[entry(3 * t + i, 3 * d + i - j, lane)] = blockEntry(block, i, j);
        }
      }
    }
  }
  // The last group's lanes past the last line: identity lines, which factor and solve to nothing.
  for (int line = lines; line < groups * kLanes; ++line) {
    double* band = factors.data() + (line / kLanes) * group_size;
    for (int dof = 0; dof < dofs; ++dof) band[entry(dof, 0, line % kLanes)] = 1.0;
  }
#pragma omp parallel for schedule(static) num_threads(threads_) if (runsInParallel(n, threads_))
  for (int group = 0; group < groups; ++group) banded_lines::factor(dofs, factors.data() + group * group_size);
}

void MultigridPreconditioner::smoothLines(int level, bool rows, bool from_zero) {
  Level& l = levels_[level];
  const GridBlockMatrix& a = l.matrix;
  const int lines = rows ? a.rows() : a.cols();
  const int length = rows ? a.cols() : a.rows();
  const int dofs = 3 * length;
  const int groups = laneGroups(lines);
  const int n = a.particles();
  if (from_zero) {
    l.solution.setZero();  // A 0 = 0: the residual is the right-hand side, no product
  } else {
    product(level, l.solution, l.residual);
  }
  const std::vector<double>& factors = rows ? l.row_factors : l.col_factors;
  const std::ptrdiff_t group_size = groupSize(dofs);
  l.line_scratch.resize(static_cast<std::size_t>(groups) * dofs * kLanes);
#pragma omp parallel for schedule(static) num_threads(threads_) if (runsInParallel(n, threads_))
  for (int group = 0; group < groups; ++group) {
    // The group's right-hand sides, dof by dof with its lines side by side (v(dof, lane)).
    double* v = l.line_scratch.data() + static_cast<std::ptrdiff_t>(group) * dofs * kLanes;
    const int first = group * kLanes;
    const int count = std::min(kLanes, lines - first);
    for (int t = 0; t < length; ++t) {
      double* v_t = v + static_cast<std::ptrdiff_t>(3 * t) * kLanes;
      for (int lane = 0; lane < kLanes; ++lane) {
        if (lane >= count) {
          for (int i = 0; i < 3; ++i) v_t[i * kLanes + lane] = 0.0;
          continue;
        }
        const int p = lineParticle(rows, a.cols(), first + lane, t);
        for (int i = 0; i < 3; ++i) {
          v_t[i * kLanes + lane] = from_zero ? l.free[p] * l.rhs(i, p) : l.free[p] * (l.rhs(i, p) - l.residual(i, p));
        }
      }
    }
    banded_lines::solve(dofs, factors.data() + group * group_size, v);
    for (int t = 0; t < length; ++t) {
      const double* v_t = v + static_cast<std::ptrdiff_t>(3 * t) * kLanes;
      for (int lane = 0; lane < count; ++lane) {
        const int p = lineParticle(rows, a.cols(), first + lane, t);
        for (int i = 0; i < 3; ++i) l.solution(i, p) += kLineSmootherWeight * l.free[p] * v_t[i * kLanes + lane];
      }
    }
  }
}

MultigridPreconditioner::Axis MultigridPreconditioner::makeAxis(int fine) {
  Axis axis;
  axis.fine = fine;
  axis.coarse = fine >= kSmallestCoarsenedSide ? (fine + 1) / 2 : fine;
  const bool coarsened = axis.coarse != fine;
  axis.parent.resize(fine);
  axis.parent2.assign(fine, -1);
  axis.weight.resize(fine);
  axis.weight2.assign(fine, 0.0);
  for (int f = 0; f < fine; ++f) {
    if (!coarsened || f % 2 == 0) {
      axis.parent[f] = coarsened ? f / 2 : f;
      axis.weight[f] = 1.0;
    } else if ((f + 1) / 2 < axis.coarse) {  // halfway between two coarse particles
      axis.parent[f] = (f - 1) / 2;
      axis.weight[f] = 0.5;
      axis.parent2[f] = (f + 1) / 2;
      axis.weight2[f] = 0.5;
    } else {  // an even side's last particle: only one coarse neighbour, which it follows (a free edge)
      axis.parent[f] = (f - 1) / 2;
      axis.weight[f] = 1.0;
    }
  }
  // The transpose, coarse index by coarse index, children in increasing fine index.
  axis.child_begin.assign(axis.coarse + 1, 0);
  for (int f = 0; f < fine; ++f) {
    ++axis.child_begin[axis.parent[f] + 1];
    if (axis.parent2[f] >= 0) ++axis.child_begin[axis.parent2[f] + 1];
  }
  for (int j = 0; j < axis.coarse; ++j) axis.child_begin[j + 1] += axis.child_begin[j];
  axis.child.resize(axis.child_begin.back());
  axis.child_weight.resize(axis.child_begin.back());
  std::vector<int> next(axis.child_begin.begin(), axis.child_begin.end() - 1);
  for (int f = 0; f < fine; ++f) {
    axis.child[next[axis.parent[f]]] = f;
    axis.child_weight[next[axis.parent[f]]++] = axis.weight[f];
    if (axis.parent2[f] >= 0) {
      axis.child[next[axis.parent2[f]]] = f;
      axis.child_weight[next[axis.parent2[f]]++] = axis.weight2[f];
    }
  }
  return axis;
}

void MultigridPreconditioner::buildCoarse(const Level& fine, Level& coarse) const {
  const GridBlockMatrix& a = fine.matrix;
  const Axis& rows = fine.row_axis;
  const Axis& cols = fine.col_axis;
  const int fine_cols = a.cols();
  coarse.matrix.reset(rows.coarse, cols.coarse, GridBlockMatrix::fullStencil());
  GridBlockMatrix& c = coarse.matrix;
  const int count = c.particles();
  const std::vector<GridOffset>& offsets = a.offsets();
  const int offset_count = static_cast<int>(offsets.size());
  coarse.free.resize(count);
  // Galerkin product P^T (S A S) P, one coarse row at a time (so each entry is summed by one thread in a
  // fixed order): for each fine child p of coarse particle I and each fine neighbour q of p, the block
  // A_pq goes to every coarse parent J of q with weight P_pI P_qJ (zero for constrained p or q). Only the
  // upper half of the stencil (J at or after I in grid order) is summed: the operator is symmetric with
  // symmetric blocks (C_IJ = C_JI), so the lower half is copied from it afterwards, which halves the
  // set-up's largest cost and makes the coarse operators exactly symmetric.
  //
  // Away from the edges the interpolation weights repeat, so the terms of one coarse particle's upper
  // half are one fixed list (target offset, child, fine offset, weight), built once here and summed
  // target by target in registers; the edges keep the general scatter below.
  struct GalerkinTerm {
    int target;           ///< coarse stencil index (upper half)
    std::ptrdiff_t p;     ///< fine child p, relative to the coarse particle's own fine particle
    int offset;           ///< fine stencil index of the coupling p -> q
    std::ptrdiff_t q;     ///< q - p
    double weight;        ///< P_pI P_qJ
  };
  std::vector<GalerkinTerm> terms;
  const bool patterned = rows.coarse != rows.fine && cols.coarse != cols.fine;
  if (patterned) {
    // Interior interpolation along one side, relative to the coarse particle's fine index 2i: an even
    // relative index e follows e / 2 with weight 1, an odd one takes half of each neighbour.
    const auto parents = [](int e, int* parent, double* weight) {
      if (e % 2 == 0) {
        parent[0] = e / 2;
        weight[0] = 1.0;
        return 1;
      }
      parent[0] = (e - 1) / 2;
      parent[1] = (e + 1) / 2;
      weight[0] = weight[1] = 0.5;
      return 2;
    };
    for (int a = -1; a <= 1; ++a) {
      for (int b = -1; b <= 1; ++b) {
        const double wp = (a == 0 ? 1.0 : 0.5) * (b == 0 ? 1.0 : 0.5);
        for (int o = 0; o < offset_count; ++o) {
          int row_parents[2], col_parents[2];
          double row_weights[2], col_weights[2];
          const int row_count = parents(a + offsets[o].dr, row_parents, row_weights);
          const int col_count = parents(b + offsets[o].dc, col_parents, col_weights);
          for (int i = 0; i < row_count; ++i) {
            for (int j = 0; j < col_count; ++j) {
              const int target = fullStencilIndex(row_parents[i], col_parents[j]);
              if (target < c.diagonalIndex()) continue;
              terms.push_back({target, static_cast<std::ptrdiff_t>(a) * fine_cols + b, o,
                               static_cast<std::ptrdiff_t>(offsets[o].dr) * fine_cols + offsets[o].dc,
                               wp * row_weights[i] * col_weights[j]});
            }
          }
        }
      }
    }
    std::stable_sort(terms.begin(), terms.end(),
                     [](const GalerkinTerm& x, const GalerkinTerm& y) { return x.target < y.target; });
  }
  // Coarse index i is interior when every fine index its terms touch, 2i - 1 - kMaxReach to
  // 2i + 1 + kMaxReach, has the interior interpolation (an even side's last fine particle does not).
  const auto interior = [](int i, const Axis& axis) {
    return 2 * i - 1 - GridBlockMatrix::kMaxReach >= 0 && 2 * i + 1 + GridBlockMatrix::kMaxReach <= axis.fine - 2;
  };
  forEachChunk(count, threads_, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index coarse_index = begin; coarse_index < end; ++coarse_index) {
      const int ci = static_cast<int>(coarse_index) / cols.coarse;
      const int cj = static_cast<int>(coarse_index) % cols.coarse;
      if (patterned && interior(ci, rows) && interior(cj, cols)) {
        const std::ptrdiff_t own = static_cast<std::ptrdiff_t>(2 * ci) * fine_cols + 2 * cj;
        double* out = c.block(static_cast<int>(coarse_index), 0);
        std::size_t k = 0;
        while (k < terms.size()) {
          const int target = terms[k].target;
          double sum[GridBlockMatrix::kBlockEntries] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
          for (; k < terms.size() && terms[k].target == target; ++k) {
            const GalerkinTerm& term = terms[k];
            const std::ptrdiff_t p = own + term.p;
            const double w = term.weight * fine.free[p] * fine.free[p + term.q];
            const double* b = a.block(static_cast<int>(p), term.offset);
            for (int e = 0; e < GridBlockMatrix::kBlockEntries; ++e) sum[e] += w * b[e];
          }
          std::copy_n(sum, GridBlockMatrix::kBlockEntries, out + target * GridBlockMatrix::kBlockEntries);
        }
      } else {
      for (int kr = rows.child_begin[ci]; kr < rows.child_begin[ci + 1]; ++kr) {
        const int fr = rows.child[kr];
        for (int kc = cols.child_begin[cj]; kc < cols.child_begin[cj + 1]; ++kc) {
          const int fc = cols.child[kc];
          const int p = fr * fine_cols + fc;
          const double wp = rows.child_weight[kr] * cols.child_weight[kc] * fine.free[p];
          if (wp == 0.0) continue;
          for (int o = 0; o < offset_count; ++o) {
            const int qr = fr + offsets[o].dr;
            const int qc = fc + offsets[o].dc;
            if (qr < 0 || qr >= a.rows() || qc < 0 || qc >= fine_cols) continue;
            if (fine.free[qr * fine_cols + qc] == 0.0) continue;
            const double* b = a.block(p, o);
            const int row_parents[2] = {rows.parent[qr], rows.parent2[qr]};
            const double row_weights[2] = {rows.weight[qr], rows.weight2[qr]};
            const int col_parents[2] = {cols.parent[qc], cols.parent2[qc]};
            const double col_weights[2] = {cols.weight[qc], cols.weight2[qc]};
            for (int i = 0; i < 2 && row_parents[i] >= 0; ++i) {
              if (row_parents[i] < ci) continue;  // the lower half: mirrored below
              for (int j = 0; j < 2 && col_parents[j] >= 0; ++j) {
                if (row_parents[i] == ci && col_parents[j] < cj) continue;
                const double w = wp * row_weights[i] * col_weights[j];
                double* target =
                    c.block(static_cast<int>(coarse_index), fullStencilIndex(row_parents[i] - ci, col_parents[j] - cj));
                for (int e = 0; e < GridBlockMatrix::kBlockEntries; ++e) target[e] += w * b[e];
              }
            }
          }
        }
      }
      }
      // A coarse particle all of whose children are constrained has an empty row: it stays fixed.
      double* diagonal = c.block(static_cast<int>(coarse_index), c.diagonalIndex());
      const bool moves = diagonal[0] + diagonal[1] + diagonal[2] > 0.0;
      coarse.free[coarse_index] = moves ? 1.0 : 0.0;
      if (!moves) {
        std::fill_n(diagonal, GridBlockMatrix::kBlockEntries, 0.0);
        diagonal[0] = diagonal[1] = diagonal[2] = 1.0;
      }
    }
  });
  // The lower half: C_I,I+d = C_I+d,I, offset d's mirror -d sits at the reversed index of the row-major
  // full stencil. Reads only upper-half blocks, which the pass above finished.
  const int stencil = static_cast<int>(c.offsets().size());
  const int diagonal_index = c.diagonalIndex();
  forEachChunk(count, threads_, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index coarse_index = begin; coarse_index < end; ++coarse_index) {
      const int ci = static_cast<int>(coarse_index) / cols.coarse;
      const int cj = static_cast<int>(coarse_index) % cols.coarse;
      for (int o = 0; o < diagonal_index; ++o) {
        const int qr = ci + c.offsets()[o].dr;
        const int qc = cj + c.offsets()[o].dc;
        if (qr < 0 || qr >= rows.coarse || qc < 0 || qc >= cols.coarse) continue;
        const double* mirror = c.block(qr * cols.coarse + qc, stencil - 1 - o);
        std::copy_n(mirror, GridBlockMatrix::kBlockEntries, c.block(static_cast<int>(coarse_index), o));
      }
    }
  });
}

void MultigridPreconditioner::setup(Dynamics& dynamics, double step_s, const Eigen::VectorXd& free) {
  dynamics_ = &dynamics;
  step_s_ = step_s;
  threads_ = dynamics.threads();
  if (levels_.empty()) levels_.resize(1);
  if (!dynamics.systemGridMatrix(step_s, levels_[0].matrix)) {
    levels_.clear();
    fallback_.setup(dynamics, step_s, free);
    return;
  }
  levels_[0].free = free;
  std::size_t count = 1;
  while (levels_[count - 1].matrix.particles() > kCoarsestParticles) {
    Level& fine = levels_[count - 1];
    fine.row_axis = makeAxis(fine.matrix.rows());
    fine.col_axis = makeAxis(fine.matrix.cols());
    if (fine.row_axis.coarse == fine.row_axis.fine && fine.col_axis.coarse == fine.col_axis.fine) break;
    if (levels_.size() == count) levels_.emplace_back();
    buildCoarse(levels_[count - 1], levels_[count]);
    ++count;
  }
  levels_.resize(count);
  for (std::size_t l = 0; l + 1 < count; ++l) {
    factorLines(levels_[l], true);
    factorLines(levels_[l], false);
  }
  for (Level& level : levels_) {
    level.rhs.resize(3, level.matrix.particles());
    level.solution.resize(3, level.matrix.particles());
    level.residual.resize(3, level.matrix.particles());
  }
  // The coarsest level directly: its dense matrix with the fixed particles' dofs decoupled.
  const Level& coarsest = levels_.back();
  Eigen::MatrixXd dense = coarsest.matrix.dense();
  for (int p = 0; p < coarsest.matrix.particles(); ++p) {
    if (coarsest.free[p] != 0.0) continue;
    dense.middleRows(3 * p, 3).setZero();
    dense.middleCols(3 * p, 3).setZero();
    dense.block<3, 3>(3 * p, 3 * p).setIdentity();
  }
  coarsest_.compute(dense);
}

void MultigridPreconditioner::product(int level, const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y) {
  if (level == 0) {
    dynamics_->systemProduct(step_s_, x, y);  // matrix-free: cheaper than the 13-block stencil
  } else {
    levels_[level].matrix.multiply(x, y, threads_);
  }
}

void MultigridPreconditioner::restrictResidual(int level) {
  Level& fine = levels_[level];
  Level& coarse = levels_[level + 1];
  product(level, fine.solution, fine.residual);  // A x; the residual b - A x is formed in the sum below
  const Axis& rows = fine.row_axis;
  const Axis& cols = fine.col_axis;
  const int fine_cols = fine.matrix.cols();
  forEachChunk(coarse.matrix.particles(), threads_, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index j = begin; j < end; ++j) {
      const int ci = static_cast<int>(j) / cols.coarse;
      const int cj = static_cast<int>(j) % cols.coarse;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (int kr = rows.child_begin[ci]; kr < rows.child_begin[ci + 1]; ++kr) {
        for (int kc = cols.child_begin[cj]; kc < cols.child_begin[cj + 1]; ++kc) {
          const int p = rows.child[kr] * fine_cols + cols.child[kc];
          const double weight = rows.child_weight[kr] * cols.child_weight[kc] * fine.free[p];
          sum += weight * (fine.rhs.col(p) - fine.residual.col(p));
        }
      }
      coarse.rhs.col(j) = coarse.free[j] * sum;
    }
  });
}

void MultigridPreconditioner::prolongateAdd(int level) {
  Level& fine = levels_[level];
  const Level& coarse = levels_[level + 1];
  const Axis& rows = fine.row_axis;
  const Axis& cols = fine.col_axis;
  const int fine_cols = fine.matrix.cols();
  forEachChunk(fine.matrix.particles(), threads_, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index p = begin; p < end; ++p) {
      if (fine.free[p] == 0.0) continue;
      const int fr = static_cast<int>(p) / fine_cols;
      const int fc = static_cast<int>(p) % fine_cols;
      const int row_parents[2] = {rows.parent[fr], rows.parent2[fr]};
      const double row_weights[2] = {rows.weight[fr], rows.weight2[fr]};
      const int col_parents[2] = {cols.parent[fc], cols.parent2[fc]};
      const double col_weights[2] = {cols.weight[fc], cols.weight2[fc]};
      for (int i = 0; i < 2 && row_parents[i] >= 0; ++i) {
        for (int j = 0; j < 2 && col_parents[j] >= 0; ++j) {
          fine.solution.col(p) +=
              (row_weights[i] * col_weights[j]) * coarse.solution.col(row_parents[i] * cols.coarse + col_parents[j]);
        }
      }
    }
  });
}

void MultigridPreconditioner::cycle(int level) {
  Level& l = levels_[level];
  if (level + 1 == static_cast<int>(levels_.size())) {
    coarsest_rhs_ = Eigen::Map<const Eigen::VectorXd>(l.rhs.data(), l.rhs.size());
    Eigen::Map<Eigen::VectorXd>(l.solution.data(), l.solution.size()) = coarsest_.solve(coarsest_rhs_);
    l.solution = l.solution * l.free.asDiagonal();
    return;
  }
  // Rows then columns before, columns then rows after: the cycle stays symmetric.
  for (int s = 0; s < kSmoothingSweeps; ++s) {
    smoothLines(level, true, s == 0);
    smoothLines(level, false, false);
  }
  restrictResidual(level);
  cycle(level + 1);
  prolongateAdd(level);
  for (int s = 0; s < kSmoothingSweeps; ++s) {
    smoothLines(level, false, false);
    smoothLines(level, true, false);
  }
}

void MultigridPreconditioner::apply(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z) {
  if (levels_.empty()) {
    fallback_.apply(r, z);
    return;
  }
  levels_[0].rhs = r * levels_[0].free.asDiagonal();
  cycle(0);
  z = levels_[0].solution;
}

}  // namespace cloth_sim::core
