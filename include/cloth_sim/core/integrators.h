// Time integration (paper §6 and its future work): one interface, one class per method, named for what it is.
#pragma once

#include "cloth_sim/core/state.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace cloth_sim::core {

class GridBlockMatrix;

/// The right-hand side of the ODE x' = v, M v' = F(x, v, t), with what an implicit method needs on top:
/// the masses, the constrained particles and the force differential. All fields are 3 x N, world frame.
class Dynamics {
 public:
  virtual ~Dynamics() = default;

  /// Forces, N: fills forces_N (3 x N; the callee resizes it) at the given positions, velocities and time.
  virtual void forces(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s, double time_s,
                      Eigen::Matrix3Xd& forces_N) = 0;
  /// Mass per particle, kg.
  virtual const Eigen::VectorXd& mass_kg() const = 0;
  /// 1 / mass per particle, 1/kg; 0 marks a constrained particle (a pin on its hook) whose motion is
  /// prescribed by constrainedPositions rather than by its forces.
  virtual const Eigen::VectorXd& inverseMass_per_kg() const = 0;
  /// Writes the prescribed positions at time_s into the constrained particles' columns; others untouched.
  virtual void constrainedPositions(double time_s, Eigen::Matrix3Xd& positions_m) const = 0;

  /// Linearises the forces at (x, v, t): afterwards forceDifferential, systemProduct and
  /// systemDiagonalBlocks use dF/dx and dF/dv taken there.
  virtual void linearize(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                         double time_s) = 0;
  /// df = dF/dx dx + dF/dv dv, N, matrix-free (3 x N each).
  virtual void forceDifferential(const Eigen::Matrix3Xd& dx_m, const Eigen::Matrix3Xd& dv_m_per_s,
                                 Eigen::Matrix3Xd& df_N) = 0;
  /// df = dF/dx dx alone. The default goes through forceDifferential with dv = 0; a model may skip the
  /// velocity part.
  virtual void stiffnessProduct(const Eigen::Matrix3Xd& dx_m, Eigen::Matrix3Xd& df_N);
  /// out = (M - h dF/dv - h^2 dF/dx) w: the backward Euler system matrix times w. The default goes
  /// through forceDifferential; a model may fuse it.
  virtual void systemProduct(double step_s, const Eigen::Matrix3Xd& w, Eigen::Matrix3Xd& out);
  /// The 3x3 diagonal blocks of that matrix, one column per particle: xx, yy, zz, xy, xz, yz.
  virtual void systemDiagonalBlocks(double step_s, Eigen::Matrix<double, 6, Eigen::Dynamic>& blocks) = 0;
  /// The same matrix assembled on the particle grid (grid_matrix.h: a symmetric 3x3 block per particle and
  /// neighbour offset), for multigrid; constrained particles are not filtered. False (the default): the
  /// dynamics has no grid, and multigrid falls back to block-Jacobi.
  virtual bool systemGridMatrix(double step_s, GridBlockMatrix& matrix);

  /// Threads the model's loops, and a solver's over its particles, may use.
  virtual int threads() const { return 1; }

  /// Accelerations, m/s^2: forces times inverse mass (so 0 for constrained particles).
  void acceleration(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s, double time_s,
                    Eigen::Matrix3Xd& accelerations_m_per_s2);

 private:
  Eigen::Matrix3Xd differential_scratch_, scaled_scratch_;
};

class Preconditioner;
class BlockJacobiPreconditioner;

/// What one step did.
struct StepReport {
  int force_evaluations = 0;  ///< calls of Dynamics::forces
  int solver_iterations = 0;  ///< conjugate-gradient iterations (implicit methods; 0 for explicit ones)
  double residual = 0.0;      ///< relative residual of the linear solve at exit (0 for explicit methods)
  bool converged = true;      ///< false: the solve stopped at its iteration cap above its tolerance
  StepReport& operator+=(const StepReport& other);
};

enum class IntegratorKind { kForwardEuler, kSymplecticEuler, kMidpoint, kRK4, kImplicitEuler };

/// All kinds: the explicit ones in order of cost, then implicit Euler.
const std::vector<IntegratorKind>& allIntegratorKinds();
/// "forward_euler", "symplectic_euler", "midpoint", "rk4", "implicit_euler": the names used in scenes and
/// parameters.
const char* integratorName(IntegratorKind kind);
/// Parses a name above; false if unknown.
bool parseIntegratorName(const std::string& name, IntegratorKind* kind);
/// The names above joined with ", " (for error messages and docs).
std::string integratorNameList();

/// The conjugate-gradient preconditioner of implicit Euler (preconditioner.h, multigrid.h).
enum class PreconditionerKind { kBlockJacobi, kMultigrid };

/// All kinds, cheapest per iteration first.
const std::vector<PreconditionerKind>& allPreconditionerKinds();
/// "block_jacobi", "multigrid": the names used in scenes and parameters (`solver_preconditioner`).
const char* preconditionerName(PreconditionerKind kind);
/// Parses a name above; false if unknown.
bool parsePreconditionerName(const std::string& name, PreconditionerKind* kind);
/// The names above joined with ", " (for error messages and docs).
std::string preconditionerNameList();

/// How hard the implicit solver works per step (conjugate gradients on the backward Euler system).
struct SolverOptions {
  /// Stop when the residual falls below this fraction of the right-hand side, both measured in the
  /// block-Jacobi norm (|r|^2 = r^T D^-1 r, D the 3x3 diagonal blocks of the system) whichever
  /// preconditioner runs, so a tolerance means the same cloth for every preconditioner.
  double tolerance = 1e-3;
  /// Stop after this many iterations even above the tolerance; the step is still taken (reported as not
  /// converged): a truncated CG solution damps the stiff modes first, so it stays stable.
  int max_iterations = 100;
  /// What preconditions the conjugate gradients: the 3x3 diagonal blocks (cheap per iteration, but the
  /// iterations grow with the grid and the stiffness) or a geometric multigrid V-cycle on the grid.
  PreconditionerKind preconditioner = PreconditionerKind::kMultigrid;
};

/// Advances positions, velocities and time by one step h. Holds its own scratch, so one instance per
/// simulation; step() allocates only when the particle count changes.
class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual IntegratorKind kind() const = 0;
  /// Order of the global error (1, 1, 2, 4, 1).
  virtual int order() const = 0;
  virtual StepReport step(Dynamics& dynamics, double step_s, ClothState& state) = 0;
  /// Says that the next `steps` calls of step() are the substeps of one frame, of equal length: a method may
  /// carry work from one of them to the next (implicit Euler's preconditioner), never past them, so a frame
  /// computed again, or after a restored snapshot, re-runs bit for bit. Without it nothing is carried.
  virtual void beginFrame(int /*steps*/) {}
  /// Takes off forces_N (N, world frame, per particle) what the last step's solve left unsolved, as a
  /// force: forces read where a step ended then say what the cloth exerts, not what the solver's
  /// tolerance left over. Nothing for a method that solves nothing (the explicit ones).
  virtual void subtractSolveShortfall(double /*step_s*/, Eigen::Matrix3Xd& /*forces_N*/) const {}
};

/// Forward (explicit) Euler: x1 = x0 + h v0, v1 = v0 + h a(x0, v0). Gains energy on any undamped spring.
class ForwardEuler final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kForwardEuler; }
  int order() const override { return 1; }
  StepReport step(Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_;
};

/// Semi-implicit (symplectic) Euler, the paper's "Euler": v1 = v0 + h a(x0, v0), x1 = x0 + h v1.
class SymplecticEuler final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kSymplecticEuler; }
  int order() const override { return 1; }
  StepReport step(Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_;
};

/// Explicit midpoint (RK2): evaluate the derivative at the half step reached with forward Euler.
class Midpoint final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kMidpoint; }
  int order() const override { return 2; }
  StepReport step(Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_, half_positions_, half_velocities_;
};

/// Classic fourth-order Runge-Kutta.
class RK4 final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kRK4; }
  int order() const override { return 4; }
  StepReport step(Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd stage_positions_, stage_velocities_, stage_acceleration_;
  Eigen::Matrix3Xd sum_position_rates_, sum_velocity_rates_;
};

/// Backward Euler linearised once per step (Baraff and Witkin 1998, "Large Steps in Cloth Simulation"):
///   (M - h dF/dv - h^2 dF/dx) dv = h (F0 + h dF/dx v0),  v1 = v0 + dv,  x1 = x0 + h v1,
/// solved matrix-free by conjugate gradients with a preconditioner (SolverOptions::preconditioner) and
/// Baraff and Witkin's constraint filter: a constrained particle's dv is fixed so that it lands exactly
/// where Dynamics::constrainedPositions puts it at t + h (pins, moving pins, hooked pins), and its rows
/// are filtered out of every residual and search direction. The solve starts from dv = 0 (a capped solve
/// then never adds energy, and a restored snapshot re-runs bit for bit). Unconditionally stable on the
/// linearised system; it damps, so energy never grows without forcing. First order.
class ImplicitEuler final : public Integrator {
 public:
  explicit ImplicitEuler(const SolverOptions& options = SolverOptions());
  ~ImplicitEuler() override;
  IntegratorKind kind() const override { return IntegratorKind::kImplicitEuler; }
  int order() const override { return 1; }
  StepReport step(Dynamics& dynamics, double step_s, ClothState& state) override;
  /// The preconditioner's last setup within a frame (at its first substep, or at one that would not carry
  /// it) serves the frame's later substeps, while their step and constrained particles are the same and
  /// their system is close (kMaxCarriedDrift): the system changes little over one frame, and conjugate
  /// gradients converge to the same tolerance with a preconditioner of a nearby system (measured in
  /// doc/BENCHMARKS.md, "One preconditioner a frame"). Only the stopping norm is set up at every step.
  void beginFrame(int steps) override;
  /// A carried preconditioner's solve that takes more than this many times the iterations of the one it was
  /// set up for, that finds it no longer positive definite (r^T z <= 0), or that stops above the tolerance,
  /// is started again from zero with one set up for its own system, within the same max_iterations.
  static constexpr int kCarriedIterationFactor = 2;
  /// A preconditioner is carried to a later substep only while no particle's inverted diagonal block has
  /// changed by more than this fraction of its largest entry since it was set up. Measured on the 64 x 64
  /// and 128 x 128 scenes: below 0.3 a carried solve took the iterations of a fresh one (the tablecloth's
  /// also up to 0.5); from 0.33 to 0.5 the curtain's and the flag's took twice as many, costing more than a
  /// setup; above 1 (a crumpling pile, a fold landing, springs buckling from one substep to the next) most
  /// did not converge within kCarriedIterationFactor times.
  static constexpr double kMaxCarriedDrift = 0.3;
  /// The residual r of the last step's system, over step_s: r = h F(end) - M dv for the force linearised
  /// as the system has it (compressed springs without their transverse part, no wind), so F(end) - r / h
  /// is the force the step's velocity change says acted, M dv / h, whatever the tolerance stopped the
  /// solve at. Not the force a converged solve would have ended with: the error a stopped solve leaves
  /// in the velocities stays. Static friction's test reads it (Simulation::integrateFrame).
  void subtractSolveShortfall(double step_s, Eigen::Matrix3Xd& forces_N) const override;

 private:
  SolverOptions options_;
  /// The block-Jacobi preconditioner measures every residual (the stopping norm); it also preconditions
  /// when options_.preconditioner asks for it, and then preconditioner_ is empty.
  std::unique_ptr<BlockJacobiPreconditioner> norm_;
  std::unique_ptr<Preconditioner> preconditioner_;
  Eigen::Matrix3Xd forces_, rhs_, dv_, residual_, direction_, product_, preconditioned_, prescribed_, measured_;
  Eigen::VectorXd free_;              ///< 1 for a free particle, 0 for a constrained one
  std::vector<double> partial_sums_;  ///< per chunk, for the deterministic dot products
  int frame_steps_left_ = 0;          ///< steps of the frame beginFrame announced still to come
  bool preconditioner_ready_ = false;  ///< preconditioner_ holds a setup that this frame's steps may use
  double prepared_step_s_ = 0.0;       ///< its step
  int prepared_iterations_ = 0;        ///< iterations of the solve it was set up for
  Eigen::VectorXd prepared_free_;      ///< and its free particles
  Eigen::Matrix<double, 6, Eigen::Dynamic> prepared_blocks_;  ///< and its system's inverted diagonal blocks
};

std::unique_ptr<Integrator> makeIntegrator(IntegratorKind kind, const SolverOptions& solver = SolverOptions());

}  // namespace cloth_sim::core
