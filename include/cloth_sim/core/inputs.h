// What the outside world feeds a running cloth, apart from its options and its state: the hands that hold
// it, the hooks its pins hang on, and the wind. Options + ClothState + ClothInputs are a complete
// snapshot of a simulation: saving and restoring exactly these three reproduces it bit for bit.
#pragma once

#include "cloth_sim/core/forces.h"

#include <Eigen/Core>

#include <algorithm>
#include <vector>

namespace cloth_sim::core {

struct ClothInputs {
  /// Mean wind velocity in force, world frame, m/s (gusts modulate it; options.wind_enabled switches it).
  Eigen::Vector3d wind_m_per_s = Eigen::Vector3d::Zero();
  /// Hands holding particles (paper §5); at most Simulation::kMaxGrasps.
  std::vector<Grasp> grasps;
  /// Pinned particles, sorted and unique (resolved from options.pins).
  std::vector<int> pins;
  /// 3 x pins.size(), world frame, m: where each pin's hook hangs before the pins' motion is added. The
  /// rest position until a released grasp hangs the pin on a new hook where it let go.
  Eigen::Matrix3Xd pin_anchors_m;
  /// 3 x pins.size(), m: how far each pin starts from its hook; it travels there over
  /// options.pin_travel_time_s. Zero once a pin is hooked again after a grasp.
  Eigen::Matrix3Xd pin_travel_m;

  /// True when a grasp holds particle i (a held pin is off its hook and moves freely).
  bool isGrasped(int particle) const {
    return std::any_of(grasps.begin(), grasps.end(), [particle](const Grasp& g) { return g.particle == particle; });
  }
};

}  // namespace cloth_sim::core
