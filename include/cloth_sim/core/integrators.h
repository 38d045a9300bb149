// Time integration (paper §6): one interface, one class per method, named for what it is.
#pragma once

#include "cloth_sim/core/state.h"

#include <Eigen/Core>

#include <memory>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// The right-hand side of the ODE x' = v, v' = a(x, v, t). An implicit integrator (later) will also ask
/// for force Jacobians; they will be added here as further virtual functions.
class Dynamics {
 public:
  virtual ~Dynamics() = default;
  /// Fills accelerations_m_per_s2 (3 x N, resized by the caller) for the given positions and velocities.
  virtual void acceleration(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                            double time_s, Eigen::Matrix3Xd& accelerations_m_per_s2) const = 0;
};

enum class IntegratorKind { kForwardEuler, kSymplecticEuler, kMidpoint, kRK4 };

/// All kinds, in order of cost.
const std::vector<IntegratorKind>& allIntegratorKinds();
/// "forward_euler", "symplectic_euler", "midpoint", "rk4": the names used in scenes and parameters.
const char* integratorName(IntegratorKind kind);
/// Parses a name above; false if unknown.
bool parseIntegratorName(const std::string& name, IntegratorKind* kind);

/// Advances positions, velocities and time by one step h. Holds its own scratch, so one instance per
/// simulation; step() allocates only when the particle count changes.
class Integrator {
 public:
  virtual ~Integrator() = default;
  virtual IntegratorKind kind() const = 0;
  /// Order of the global error (1, 1, 2, 4).
  virtual int order() const = 0;
  virtual void step(const Dynamics& dynamics, double step_s, ClothState& state) = 0;
};

/// Forward (explicit) Euler: x1 = x0 + h v0, v1 = v0 + h a(x0, v0). Gains energy on any undamped spring.
class ForwardEuler final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kForwardEuler; }
  int order() const override { return 1; }
  void step(const Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_;
};

/// Semi-implicit (symplectic) Euler, the paper's "Euler": v1 = v0 + h a(x0, v0), x1 = x0 + h v1.
class SymplecticEuler final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kSymplecticEuler; }
  int order() const override { return 1; }
  void step(const Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_;
};

/// Explicit midpoint (RK2): evaluate the derivative at the half step reached with forward Euler.
class Midpoint final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kMidpoint; }
  int order() const override { return 2; }
  void step(const Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd acceleration_, half_positions_, half_velocities_;
};

/// Classic fourth-order Runge-Kutta.
class RK4 final : public Integrator {
 public:
  IntegratorKind kind() const override { return IntegratorKind::kRK4; }
  int order() const override { return 4; }
  void step(const Dynamics& dynamics, double step_s, ClothState& state) override;

 private:
  Eigen::Matrix3Xd stage_positions_, stage_velocities_, stage_acceleration_;
  Eigen::Matrix3Xd sum_position_rates_, sum_velocity_rates_;
};

std::unique_ptr<Integrator> makeIntegrator(IntegratorKind kind);

}  // namespace cloth_sim::core
