#include "cloth_sim/core/integrators.h"

namespace cloth_sim::core {

const std::vector<IntegratorKind>& allIntegratorKinds() {
  static const std::vector<IntegratorKind> kinds{IntegratorKind::kForwardEuler, IntegratorKind::kSymplecticEuler,
                                                 IntegratorKind::kMidpoint, IntegratorKind::kRK4};
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

void ForwardEuler::step(const Dynamics& dynamics, double step_s, ClothState& state) {
  acceleration_.resize(3, state.particleCount());
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  state.positions_m += step_s * state.velocities_m_per_s;  // the old velocity: this is what makes it forward
  state.velocities_m_per_s += step_s * acceleration_;
  state.time_s += step_s;
}

void SymplecticEuler::step(const Dynamics& dynamics, double step_s, ClothState& state) {
  acceleration_.resize(3, state.particleCount());
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  state.velocities_m_per_s += step_s * acceleration_;
  state.positions_m += step_s * state.velocities_m_per_s;  // the new velocity (paper §6)
  state.time_s += step_s;
}

void Midpoint::step(const Dynamics& dynamics, double step_s, ClothState& state) {
  const double half_s = 0.5 * step_s;
  acceleration_.resize(3, state.particleCount());
  dynamics.acceleration(state.positions_m, state.velocities_m_per_s, state.time_s, acceleration_);
  half_positions_ = state.positions_m + half_s * state.velocities_m_per_s;
  half_velocities_ = state.velocities_m_per_s + half_s * acceleration_;
  dynamics.acceleration(half_positions_, half_velocities_, state.time_s + half_s, acceleration_);
  state.positions_m += step_s * half_velocities_;
  state.velocities_m_per_s += step_s * acceleration_;
  state.time_s += step_s;
}

void RK4::step(const Dynamics& dynamics, double step_s, ClothState& state) {
  const Eigen::Matrix3Xd& x0 = state.positions_m;
  const Eigen::Matrix3Xd& v0 = state.velocities_m_per_s;
  const double t0 = state.time_s;
  stage_acceleration_.resize(3, state.particleCount());

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
}

std::unique_ptr<Integrator> makeIntegrator(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kForwardEuler:
      return std::make_unique<ForwardEuler>();
    case IntegratorKind::kSymplecticEuler:
      return std::make_unique<SymplecticEuler>();
    case IntegratorKind::kMidpoint:
      return std::make_unique<Midpoint>();
    case IntegratorKind::kRK4:
      return std::make_unique<RK4>();
  }
  return nullptr;
}

}  // namespace cloth_sim::core
