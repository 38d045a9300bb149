#include "cloth_sim/core/integrators.h"

#include "cloth_sim/core/preconditioner.h"

#include "parallel.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cloth_sim::core {

void Dynamics::acceleration(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                            double time_s, Eigen::Matrix3Xd& accelerations_m_per_s2) {
  forces(positions_m, velocities_m_per_s, time_s, accelerations_m_per_s2);
  accelerations_m_per_s2 = accelerations_m_per_s2 * inverseMass_per_kg().asDiagonal();
}

void Dynamics::stiffnessProduct(const Eigen::Matrix3Xd& dx_m, Eigen::Matrix3Xd& df_N) {
  differential_scratch_.setZero(3, dx_m.cols());
  forceDifferential(dx_m, differential_scratch_, df_N);
}

void Dynamics::systemProduct(double step_s, const Eigen::Matrix3Xd& w, Eigen::Matrix3Xd& out) {
  scaled_scratch_ = (step_s * step_s) * w;
  differential_scratch_ = step_s * w;
  forceDifferential(scaled_scratch_, differential_scratch_, out);
  out = w * mass_kg().asDiagonal() - out;
}

bool Dynamics::systemGridMatrix(double, GridBlockMatrix&) { return false; }

StepReport& StepReport::operator+=(const StepReport& other) {
  force_evaluations += other.force_evaluations;
  solver_iterations += other.solver_iterations;
  residual = std::max(residual, other.residual);
  converged = converged && other.converged;
  return *this;
}

const std::vector<IntegratorKind>& allIntegratorKinds() {
  static const std::vector<IntegratorKind> kinds{IntegratorKind::kForwardEuler, IntegratorKind::kSymplecticEuler,
                                                 IntegratorKind::kMidpoint, IntegratorKind::kRK4,
                                                 IntegratorKind::kImplicitEuler};
  return kinds;
}

const char* integratorName(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kForwardEuler:
      return "forward_euler";
    case IntegratorKind::kSymplecticEuler:
      return "symplectic_euler";
    case IntegratorKind::kMidpoint:
      return "midpoint";
    case IntegratorKind::kRK4:
      return "rk4";
    case IntegratorKind::kImplicitEuler:
      return "implicit_euler";
  }
  return "unknown";
}

bool parseIntegratorName(const std::string& name, IntegratorKind* kind) {
  for (IntegratorKind candidate : allIntegratorKinds()) {
    if (name == integratorName(candidate)) {
      *kind = candidate;
      return true;
    }
  }
  return false;
}

std::string integratorNameList() {
  std::string names;
  for (IntegratorKind kind : allIntegratorKinds()) names += (names.empty() ? "" : ", ") + std::string(integratorName(kind));
  return names;
}

StepReport ForwardEuler::step(Dynamics& dynamics, double step_s, ClothState& state) {
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  state.positions_m += step_s * state.velocities_m_per_s;  // the old velocity: this is what makes it forward
  state.velocities_m_per_s += step_s * acceleration_;
  state.time_s += step_s;
  return {1, 0, 0.0, true};
}

StepReport SymplecticEuler::step(Dynamics& dynamics, double step_s, ClothState& state) {
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  state.velocities_m_per_s += step_s * acceleration_;
  state.positions_m += step_s * state.velocities_m_per_s;  // the new velocity (paper §6)
  state.time_s += step_s;
  return {1, 0, 0.0, true};
}

StepReport Midpoint::step(Dynamics& dynamics, double step_s, ClothState& state) {
  const double half_s = 0.5 * step_s;
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  half_positions_ = state.positions_m + half_s * state.velocities_m_per_s;
  half_velocities_ = state.velocities_m_per_s + half_s * acceleration_;
  dynamics.acceleration(half_positions_, half_velocities_, state.time_s + half_s, acceleration_);
  state.positions_m += step_s * half_velocities_;
  state.velocities_m_per_s += step_s * acceleration_;
  state.time_s += step_s;
  return {2, 0, 0.0, true};
}

StepReport RK4::step(Dynamics& dynamics, double step_s, ClothState& state) {
  const Eigen::Matrix3Xd& x0 = state.positions_m;
  const Eigen::Matrix3Xd& v0 = state.velocities_m_per_s;
  const double t0 = state.time_s;

  // k1 at the start.
  dynamics.acceleration(x0, v0, t0, stage_acceleration_);
  sum_position_rates_ = v0;
  sum_velocity_rates_ = stage_acceleration_;
  stage_velocities_ = v0;  // k1's position rate
  // k2 and k3 at the half step, k4 at the end; weights 1, 2, 2, 1.
  const double stage_offsets[3] = {0.5, 0.5, 1.0};
  const double stage_weights[3] = {2.0, 2.0, 1.0};
  for (int stage = 0; stage < 3; ++stage) {
    const double offset_s = stage_offsets[stage] * step_s;
    // The previous stage's rates are (stage_velocities_, stage_acceleration_).
    stage_positions_ = x0 + offset_s * stage_velocities_;
    stage_velocities_ = v0 + offset_s * stage_acceleration_;
    dynamics.acceleration(stage_positions_, stage_velocities_, t0 + offset_s, stage_acceleration_);
    sum_position_rates_ += stage_weights[stage] * stage_velocities_;
    sum_velocity_rates_ += stage_weights[stage] * stage_acceleration_;
  }
  state.positions_m += (step_s / 6.0) * sum_position_rates_;
  state.velocities_m_per_s += (step_s / 6.0) * sum_velocity_rates_;
  state.time_s += step_s;
  return {4, 0, 0.0, true};
}

namespace {

/// Sum of a_i . b_i over the particles [begin, end).
double residualDot(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b, Eigen::Index begin, Eigen::Index end) {
  double sum = 0.0;
  for (Eigen::Index i = begin; i < end; ++i) sum += a.col(i).dot(b.col(i));
  return sum;
}

/// The largest change, over the particles, of an inverted diagonal block (xx yy zz xy xz yz) from `before`
/// to `now`, relative to the block's largest entry before.
double blockDrift(const Eigen::Matrix<double, 6, Eigen::Dynamic>& before,
                  const Eigen::Matrix<double, 6, Eigen::Dynamic>& now) {
  if (before.cols() != now.cols()) return std::numeric_limits<double>::infinity();
  double drift = 0.0;
  for (Eigen::Index i = 0; i < now.cols(); ++i) {
    drift = std::max(drift, (now.col(i) - before.col(i)).cwiseAbs().maxCoeff() / before.col(i).cwiseAbs().maxCoeff());
  }
  return drift;
}

}  // namespace

ImplicitEuler::ImplicitEuler(const SolverOptions& options)
    : options_(options), norm_(std::make_unique<BlockJacobiPreconditioner>()) {
  if (options_.preconditioner != PreconditionerKind::kBlockJacobi) {
    preconditioner_ = makePreconditioner(options_.preconditioner);
  }
}

ImplicitEuler::~ImplicitEuler() = default;

StepReport ImplicitEuler::step(Dynamics& dynamics, double step_s, ClothState& state) {
  const Eigen::Index count = state.positions_m.cols();
  const double h = step_s;
  const Eigen::Matrix3Xd& x0 = state.positions_m;
  const Eigen::Matrix3Xd& v0 = state.velocities_m_per_s;
  StepReport report;

  dynamics.forces(x0, v0, state.time_s, forces_);
  report.force_evaluations = 1;
  dynamics.linearize(x0, v0, state.time_s);

  // Right-hand side h (F0 + h dF/dx v0), filtered.
  free_ = (dynamics.inverseMass_per_kg().array() > 0.0).cast<double>();
  direction_ = h * v0;
  dynamics.stiffnessProduct(direction_, product_);  // h dF/dx v0
  rhs_ = h * (forces_ + product_);

  // Free particles start from dv = 0. Conjugate gradients started at zero grow the solution's energy
  // norm monotonically towards the exact one, so a solve cut off at its iteration cap never injects
  // energy; a start from explicit Euler's dv (h F0 / m) carries that method's unstable stiff modes, and a
  // truncated solve does not remove them all (measured: it diverges at 128x128). Constrained particles:
  // dv takes them exactly to their prescribed positions at t + h.
  dv_.setZero(3, count);
  prescribed_ = x0;
  dynamics.constrainedPositions(state.time_s + h, prescribed_);
  for (Eigen::Index i = 0; i < count; ++i) {
    if (free_[i] == 0.0) dv_.col(i) = (prescribed_.col(i) - x0.col(i)) / h - v0.col(i);
  }

  // The stopping norm is block-Jacobi's whichever preconditioner runs: r^T D^-1 r (D the diagonal
  // blocks), so the tolerance means the same residual, and the same cloth, for every preconditioner.
  norm_->setup(dynamics, h, free_);
  Preconditioner& preconditioner = preconditioner_ ? *preconditioner_ : *norm_;
  const bool in_frame = frame_steps_left_ > 0;
  frame_steps_left_ = std::max(frame_steps_left_ - 1, 0);
  // Worth keeping only for a later step of this frame (not after a frame's last, or only, step).
  const bool steps_to_come = frame_steps_left_ > 0;
  bool carried = preconditioner_ && in_frame && preconditioner_ready_ && h == prepared_step_s_ &&
                prepared_free_.size() == free_.size() && free_ == prepared_free_ &&
                blockDrift(prepared_blocks_, norm_->inverseBlocks()) <= kMaxCarriedDrift;
  const auto setUp = [&]() {
    preconditioner_->setup(dynamics, h, free_);
    preconditioner_ready_ = steps_to_come;
    if (!steps_to_come) return;
    prepared_step_s_ = h;
    prepared_free_ = free_;
    prepared_blocks_ = norm_->inverseBlocks();
  };
  if (preconditioner_ && !carried) setUp();
  const bool measured_by_preconditioner = !preconditioner_;
  const int threads = dynamics.threads();
  const auto dot = [&](const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
    return deterministicSum(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
      return residualDot(a, b, begin, end);
    }, partial_sums_);
  };
  const auto normSquared = [&](const Eigen::Matrix3Xd& r) {
    measured_.resize(3, count);
    return deterministicSum(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
      norm_->applyRange(r, measured_, begin, end);
      return residualDot(r, measured_, begin, end);
    }, partial_sums_);
  };
  // Measured against the right-hand side, never against the first residual: a poor start must not
  // loosen the tolerance.
  product_ = rhs_ * free_.asDiagonal();
  const double rhs_norm = normSquared(product_);
  preconditioned_.resize(3, count);
  // A preconditioner carried over from an earlier substep may fit this system badly (the layers of a fold
  // landing change it within a frame): past kCarriedIterationFactor times the iterations of the step that
  // set it up, or where it stops being positive definite for this system, the solve starts again from
  // zero with one set up for this system, within what is left of max_iterations (a cap on the step).
  const int carried_limit = kCarriedIterationFactor * std::max(prepared_iterations_, 1);
  int iteration = 0;
  double measured = 0.0;
  double reference = 0.0;
  double target = 0.0;
  for (bool done = false; !done;) {
    // Baraff and Witkin's modified PCG: every residual and direction filtered to the free particles. Sums
    // do not depend on the thread count.
    for (Eigen::Index i = 0; i < count; ++i) {
      if (free_[i] != 0.0) dv_.col(i).setZero();
    }
    dynamics.systemProduct(h, dv_, product_);
    residual_ = (rhs_ - product_) * free_.asDiagonal();
    preconditioner.apply(residual_, direction_);
    double delta = dot(residual_, direction_);
    measured = measured_by_preconditioner ? delta : normSquared(residual_);
    reference = rhs_norm > 0.0 ? rhs_norm : measured;
    target = options_.tolerance * options_.tolerance * reference;
    const int first_iteration = iteration;
    bool gave_up = false;  // on a carried preconditioner
    while (iteration < options_.max_iterations && measured > target) {
      if (carried && iteration - first_iteration >= carried_limit) {
        gave_up = true;
        break;
      }
      dynamics.systemProduct(h, direction_, product_);
      const double curvature = deterministicSum(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
        double sum = 0.0;
        for (Eigen::Index i = begin; i < end; ++i) {
          product_.col(i) *= free_[i];
          sum += direction_.col(i).dot(product_.col(i));
        }
        return sum;
      }, partial_sums_);
      if (!(curvature > 0.0)) break;  // only with non-finite input: the system is positive definite
      const double alpha = delta / curvature;
      forEachChunk(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
        dv_.middleCols(begin, end - begin) += alpha * direction_.middleCols(begin, end - begin);
        residual_.middleCols(begin, end - begin) -= alpha * product_.middleCols(begin, end - begin);
      });
      ++iteration;
      preconditioner.apply(residual_, preconditioned_);
      const double delta_next = dot(residual_, preconditioned_);
      measured = measured_by_preconditioner ? delta_next : normSquared(residual_);
      // r^T z <= 0 for r != 0: the carried V-cycle is no longer positive definite for this system.
      if (carried && !(delta_next > 0.0) && measured > target) {
        gave_up = true;
        break;
      }
      const double beta = delta_next / delta;
      forEachChunk(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
        direction_.middleCols(begin, end - begin) =
            preconditioned_.middleCols(begin, end - begin) + beta * direction_.middleCols(begin, end - begin);
      });
      delta = delta_next;
    }
    if (carried && (gave_up || !(measured <= target)) && iteration < options_.max_iterations) {
      setUp();
      carried = false;
    } else {
      if (!carried) prepared_iterations_ = iteration - first_iteration;
      done = true;
    }
  }
  report.solver_iterations = iteration;
  report.residual = reference > 0.0 ? std::sqrt(std::max(measured, 0.0) / reference) : 0.0;
  report.converged = measured <= target;

  state.velocities_m_per_s += dv_;
  state.positions_m += h * state.velocities_m_per_s;
  state.time_s += h;
  return report;
}

void ImplicitEuler::beginFrame(int steps) {
  frame_steps_left_ = std::max(steps, 0);
  preconditioner_ready_ = false;
}

void ImplicitEuler::subtractSolveShortfall(double step_s, Eigen::Matrix3Xd& forces_N) const {
  // Constrained particles' residuals are filtered to zero: their forces stay as read.
  if (residual_.cols() != forces_N.cols() || !(step_s > 0.0)) return;
  forces_N -= residual_ / step_s;
}

std::unique_ptr<Integrator> makeIntegrator(IntegratorKind kind, const SolverOptions& solver) {
  switch (kind) {
    case IntegratorKind::kForwardEuler:
      return std::make_unique<ForwardEuler>();
    case IntegratorKind::kSymplecticEuler:
      return std::make_unique<SymplecticEuler>();
    case IntegratorKind::kMidpoint:
      return std::make_unique<Midpoint>();
    case IntegratorKind::kRK4:
      return std::make_unique<RK4>();
    case IntegratorKind::kImplicitEuler:
      return std::make_unique<ImplicitEuler>(solver);
  }
  return nullptr;
}

}  // namespace cloth_sim::core
