// Stateless force kernels (paper §2, §3, §5). Each one reads positions/velocities as flat 3 x N arrays
// and adds its force, in newtons, world frame, into `forces_N` (3 x N). None allocates; the caller
// skips a kernel entirely when its term is switched off, so an unused term costs nothing.
#pragma once

#include "cloth_sim/core/grid.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace cloth_sim::core {

/// One spring kind's constants (paper eq. 1).
struct SpringOptions {
  bool enabled = true;
  double stiffness_N_per_m = 0.0;   ///< Ks
  double damping_N_s_per_m = 0.0;   ///< Kd, on the relative velocity along the spring
  /// 0: a compressed spring pushes back as Ks (L - l). Else it pushes back at most buckling_N_m3 / L^3 N
  /// (L its rest length): the Euler load of the strip of fabric it stands for, which buckles below the
  /// grid's cells (Choi and Ko 2002's post-buckling response; `compression_model: buckling`).
  double buckling_N_m3 = 0.0;
};

/// The most a compressed spring of rest length L pushes back, N: infinite for a linear spring.
double springCompressionCap_N(const SpringOptions& options, double rest_length_m);

/// Springs: F = max(Ks (|d| - L), -cap) d/|d| + Kd ((v_j - v_i) . d/|d|) d/|d| on particle i with
/// d = x_j - x_i and cap = springCompressionCap_N, and the opposite on j. A spring shorter than a
/// micrometre has no direction and is skipped.
void accumulateSpringForces(const SpringSet& springs, const SpringOptions& options,
                            const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                            Eigen::Matrix3Xd& forces_N);

/// Gravity: F = m g per particle.
void accumulateGravity(const Eigen::VectorXd& mass_kg, const Eigen::Vector3d& gravity_m_per_s2,
                       Eigen::Matrix3Xd& forces_N);

/// Linear air damping (paper §3.2): F = -K_damp v per particle.
void accumulateAirDamping(double damping_N_s_per_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                          Eigen::Matrix3Xd& forces_N);

/// How wind turns into force on a triangle (paper §3.1 and its physical variant).
enum class WindModel {
  /// The paper's: a wind force F_w = coefficient * wind velocity per triangle; its normal part
  /// (F_w . N) N is shared equally by the three corners. Ignores cloth motion and triangle size.
  kPaper,
  /// Quadratic drag on the velocity of the wind relative to the triangle's mean velocity:
  /// F = 1/2 rho C_d A (v_rel . N) |v_rel . N| N, shared equally. Scales with area and resolution.
  kAerodynamic,
};

struct WindOptions {
  WindModel model = WindModel::kPaper;
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();  ///< mean wind, world frame
  double paper_coefficient_N_s_per_m = 0.001;  ///< kPaper: force per triangle per m/s of wind
  double air_density_kg_per_m3 = 1.2;          ///< kAerodynamic: rho
  double drag_coefficient = 1.0;               ///< kAerodynamic: C_d of a flat plate across the flow
  double gust_amplitude = 0.0;                 ///< relative: wind(t) = mean * (1 + a sin(2 pi t / period))
  double gust_period_s = 1.0;
};

/// The wind velocity at time t, gusts included.
Eigen::Vector3d windVelocityAt(const WindOptions& options, double time_s);

/// Wind on every triangle of the grid (three indices per triangle), for the given wind velocity.
void accumulateWindForces(const std::vector<int>& triangles, const WindOptions& options,
                          const Eigen::Vector3d& wind_velocity_m_per_s, const Eigen::Matrix3Xd& positions_m,
                          const Eigen::Matrix3Xd& velocities_m_per_s, Eigen::Matrix3Xd& forces_N);

/// A hand holding one particle (paper §5, F_mouse): a damped spring to the target plus a constant force.
struct Grasp {
  std::uint32_t id = 0;                 ///< caller's handle; several grasps act at once
  int particle = 0;                     ///< grid index of the held particle
  Eigen::Vector3d target_m = Eigen::Vector3d::Zero();  ///< where the hand is, world frame
  double stiffness_N_per_m = 0.0;
  double damping_N_s_per_m = 0.0;       ///< on the particle's absolute velocity (the hand is slow)
  Eigen::Vector3d extra_force_N = Eigen::Vector3d::Zero();  ///< world frame (the simulation's), N
};

/// Grasps: F = k (target - x) - c v + extra on each held particle.
void accumulateGraspForces(const std::vector<Grasp>& grasps, const Eigen::Matrix3Xd& positions_m,
                           const Eigen::Matrix3Xd& velocities_m_per_s, Eigen::Matrix3Xd& forces_N);

/// Elastic energy of one spring kind, J: sum of Ks (|d| - L)^2 / 2, except past the compression cap c
/// (springCompressionCap_N; Ks (L - |d|) > c), where the force is constant and the energy grows linearly
/// in the compression: c^2 / (2 Ks) + c (L - |d| - c / Ks).
double springPotentialEnergy(const SpringSet& springs, const SpringOptions& options,
                             const Eigen::Matrix3Xd& positions_m);

/// Largest relative stretch (|d| - L) / L over a spring set (0 for an empty set).
double maxSpringStrain(const SpringSet& springs, const Eigen::Matrix3Xd& positions_m);

}  // namespace cloth_sim::core
