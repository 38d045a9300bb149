// A geometric multigrid V-cycle on the particle grid as the preconditioner of implicit Euler's conjugate
// gradients (doc/PHYSICS.md, "Multigrid"): its iterations to a tolerance stay nearly flat as the grid
// grows and the springs stiffen, where block-Jacobi's grow with both.
//
//  - Levels: every other particle along each side of 3 or more (n -> (n + 1) / 2; an even side's last
//    particle interpolates from the one coarse particle next to it), down to kCoarsestParticles.
//  - Transfer: bilinear interpolation P, restriction its transpose (full weighting), with Tamstorf, Jones
//    and McCormick's (2015) constraint filter: P's rows for constrained particles are zero, so no coarse
//    correction moves a pin, a hook or a grasped pin, and the coarse operators are Galerkin products
//    P^T S A S P (S the free mask) that know it.
//  - Smoother: weighted line Jacobi, alternating: every grid row solved exactly for its own couplings
//    (a banded Cholesky factor per line), then every column; columns then rows after the coarse
//    correction, so the cycle is symmetric positive definite, as CG needs. Stiff structural springs
//    against soft shear make each displacement component strongly coupled along one grid direction: a
//    point smoother damped that poorly (iterations grew with the stiffness), a line smoother does not.
//    Each line reads only the previous sweep, so results do not depend on the thread count.
//  - Coarsest level: a dense LDLT factorisation.
// The finest level's products go through Dynamics::systemProduct (matrix-free); the coarse operators are
// GridBlockMatrix stencils. Everything is rebuilt in setup(), so nothing carries over between steps.
#pragma once

#include "cloth_sim/core/grid_matrix.h"
#include "cloth_sim/core/preconditioner.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <vector>

namespace cloth_sim::core {

class MultigridPreconditioner final : public Preconditioner {
 public:
  /// The coarsest level has at most this many particles; solved directly (a 3n x 3n LDLT factor).
  static constexpr int kCoarsestParticles = 64;
  /// Line-smoothing sweeps before and after each coarse correction, and their weight: a sweep solves
  /// every grid row, then every column, exactly for its own couplings (a banded Cholesky per line).
  static constexpr int kSmoothingSweeps = 1;
  static constexpr double kLineSmootherWeight = 0.7;

  PreconditionerKind kind() const override { return PreconditionerKind::kMultigrid; }
  /// Falls back to block-Jacobi when the dynamics has no grid (Dynamics::systemGridMatrix says false).
  void setup(Dynamics& dynamics, double step_s, const Eigen::VectorXd& free) override;
  void apply(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z) override;

  /// Levels of the last setup, finest first (0 when it fell back to block-Jacobi).
  int levels() const { return static_cast<int>(levels_.size()); }

 private:
  /// Interpolation along one side: fine index f takes weight[f] of coarse parent[f] and weight2[f] of
  /// parent2[f] (-1: none). A side of 2 or fewer particles is not coarsened (the identity).
  struct Axis {
    int fine = 0;
    int coarse = 0;
    std::vector<int> parent, parent2;
    std::vector<double> weight, weight2;
    /// Fine children of coarse index j: child[child_begin[j] .. child_begin[j + 1]) with child_weight.
    std::vector<int> child_begin, child;
    std::vector<double> child_weight;
  };
  struct Level {
    GridBlockMatrix matrix;                                   ///< the operator (level 0: S A S's blocks)
    Eigen::VectorXd free;                                     ///< 1 for a dof that may move, else 0
    Axis row_axis, col_axis;                                  ///< transfer to the next coarser level
    Eigen::Matrix3Xd rhs, solution;
    Eigen::Matrix3Xd residual;  ///< scratch: A solution (the residual is formed where it is read)
    /// Banded Cholesky factors of every row's and every column's own couplings (the line smoother), in
    /// groups of lines solved side by side, and the right-hand sides in the same order (multigrid.cpp).
    std::vector<double> row_factors, col_factors;
    std::vector<double> line_scratch;
  };

  static Axis makeAxis(int fine);
  void buildCoarse(const Level& fine, Level& coarse) const;
  void product(int level, const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y);
  void restrictResidual(int level);
  void prolongateAdd(int level);
  void cycle(int level);
  void factorLines(Level& level, bool rows) const;
  /// x += weight L^-1 (b - A x), L the lines' own couplings (rows or columns).
  /// from_zero: x starts at 0 (no product needed).
  void smoothLines(int level, bool rows, bool from_zero);

  Dynamics* dynamics_ = nullptr;
  double step_s_ = 0.0;
  int threads_ = 1;
  std::vector<Level> levels_;
  Eigen::LDLT<Eigen::MatrixXd> coarsest_;
  Eigen::VectorXd coarsest_rhs_;
  BlockJacobiPreconditioner fallback_;
};

}  // namespace cloth_sim::core
