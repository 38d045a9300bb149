// The integrated state of a cloth: what a step advances and what a rollback restores.
#pragma once

#include <Eigen/Core>

#include <cstdint>

namespace cloth_sim::core {

/// Everything an integrator advances, and nothing else. Forces, normals and contact data are scratch
/// that is recomputed from this, so copying a ClothState is what a rollback restores. A complete snapshot
/// (SimulationSnapshot) adds the options, the inputs and the guard's memory.
struct ClothState {
  Eigen::Matrix3Xd positions_m;         ///< 3 x N, world frame, m. Written by Integrator::step and contacts.
  Eigen::Matrix3Xd velocities_m_per_s;  ///< 3 x N, world frame, m/s. Written by Integrator::step and contacts.
  double time_s = 0.0;                  ///< simulated time, s. Drives pins, spheres and gusts.
  std::uint64_t frame = 0;              ///< frames completed since the scene started

  int particleCount() const { return static_cast<int>(positions_m.cols()); }
};

/// True when every position and velocity is finite and every coordinate is within bound_m of the
/// origin (a diverging explicit integrator leaves such a box long before it overflows).
bool isFiniteAndBounded(const ClothState& state, double bound_m);

}  // namespace cloth_sim::core
