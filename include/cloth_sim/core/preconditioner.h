// The seam between implicit Euler's conjugate gradients and what preconditions them: set up once per step
// for that step's system (M - h dF/dv - h^2 dF/dx), then applied once per iteration. Implementations keep
// nothing from one setup to the next (setup rebuilds everything), and give the same bits for any thread
// count. Implicit Euler may leave a frame's later substeps with the setup of its first
// (ImplicitEuler::beginFrame), never a later frame, so a restored snapshot re-runs bit for bit.
#pragma once

#include "cloth_sim/core/integrators.h"

#include <Eigen/Core>

#include <memory>

namespace cloth_sim::core {

class Preconditioner {
 public:
  virtual ~Preconditioner() = default;
  virtual PreconditionerKind kind() const = 0;
  /// Prepares for the backward Euler system of step h, at the linearisation dynamics.linearize last took.
  /// free: 1 for a free particle, 0 for a constrained one (inverseMass 0), whose dof must not move.
  virtual void setup(Dynamics& dynamics, double step_s, const Eigen::VectorXd& free) = 0;
  /// z = P^-1 r, an approximate solve of the system for r (3 x N, zero on constrained particles); z is
  /// zero on constrained particles. P^-1 is symmetric positive definite on the free particles.
  virtual void apply(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z) = 0;
};

/// The inverted 3x3 diagonal blocks of the system, one per particle (zero on constrained particles).
class BlockJacobiPreconditioner final : public Preconditioner {
 public:
  PreconditionerKind kind() const override { return PreconditionerKind::kBlockJacobi; }
  void setup(Dynamics& dynamics, double step_s, const Eigen::VectorXd& free) override;
  void apply(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z) override;
  /// z = P^-1 r for particles [begin, end) only (for loops that fuse it with other work).
  void applyRange(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z, Eigen::Index begin, Eigen::Index end) const;
  /// The inverted diagonal blocks of the last setup, one column per particle: xx yy zz xy xz yz.
  const Eigen::Matrix<double, 6, Eigen::Dynamic>& inverseBlocks() const { return blocks_; }

 private:
  Eigen::Matrix<double, 6, Eigen::Dynamic> blocks_;  ///< inverted diagonal blocks, xx yy zz xy xz yz
  Eigen::VectorXd free_;
  int threads_ = 1;
};

/// Inverts a symmetric 3x3 block (xx, yy, zz, xy, xz, yz) in place. The backward Euler blocks are M plus
/// positive semi-definite terms, so positive definite; a block that is not (only possible with
/// non-finite input) becomes the inverse of its diagonal.
void invertSymmetricBlock(double* block);

std::unique_ptr<Preconditioner> makePreconditioner(PreconditionerKind kind);

}  // namespace cloth_sim::core
