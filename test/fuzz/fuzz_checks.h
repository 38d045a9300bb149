// Checks shared by the libFuzzer targets: a broken promise aborts, which libFuzzer records as a finding
// (with the input that caused it) just like a crash or a sanitizer report.
#pragma once

#include "cloth_sim/core/simulation.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace cloth_sim::fuzz {

/// Aborts with `what` when `condition` is false.
inline void require(bool condition, const char* what) {
  if (condition) return;
  std::fprintf(stderr, "fuzz check failed: %s\n", what);
  std::abort();
}

/// Everything a running simulation hands out (state, energies, strain, sphere centres) must be finite,
/// whatever it was fed: the node publishes all of it.
inline void requireFiniteSimulation(const core::Simulation& simulation, const core::FrameReport& report) {
  const core::ClothState& state = simulation.state();
  require(state.positions_m.allFinite(), "a position is not finite");
  require(state.velocities_m_per_s.allFinite(), "a velocity is not finite");
  require(std::isfinite(state.time_s), "the simulated time is not finite");
  const core::EnergyReport energy = simulation.energies();
  require(std::isfinite(energy.kinetic_J), "the kinetic energy is not finite");
  require(std::isfinite(energy.potential_J), "the potential energy is not finite");
  require(std::isfinite(report.max_strain), "the frame's strain is not finite");
  for (const Eigen::Vector3d& center : simulation.sphereCenters()) {
    require(center.allFinite(), "a sphere centre is not finite");
  }
}

}  // namespace cloth_sim::fuzz
