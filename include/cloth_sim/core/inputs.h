// What the outside world feeds a running cloth, apart from its options and its state: the hands that hold
// it, the hooks its pins hang on, and the wind. Options + ClothState + ClothInputs are a complete
// snapshot of a simulation: saving and restoring exactly these three reproduces it bit for bit.
#pragma once

#include "cloth_sim/core/forces.h"
#include "cloth_sim/core/frame_colliders.h"
#include "cloth_sim/core/kinematics.h"

#include <Eigen/Core>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// A gripper: particles held rigidly in a tf frame (issue 14). Each keeps the offset it had in the frame
/// when it was attached; the frame's motion over the current frame is `track` (world frame), so the held
/// particles follow it, rotation included, as a hard constraint in every integrator (Kinematics).
struct Gripper {
  std::uint32_t id = 0;
  std::string frame;           ///< the tf frame it follows (the core only carries the name, for messages)
  std::vector<int> particles;  ///< held particles, in the order they were attached
  Eigen::Matrix3Xd offsets_m;  ///< 3 x particles.size(): each particle's place in the gripper's frame, m
  /// N: a held particle whose reaction exceeds this slips out of the gripper (0: never).
  double max_force_N = 0.0;
  /// From the pose at the start of the current frame to the pose at its end.
  PoseTrack track;
};

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

  /// Grippers holding particles rigidly (Simulation::attachGripper); at most Simulation::kMaxGrippers.
  std::vector<Gripper> grippers;
  /// Where each of options.colliders.frames is over the current frame (Simulation::moveFrameCollider), one
  /// per collider, in that order.
  std::vector<FrameColliderTrack> frame_colliders;

  /// True when a grasp holds particle i (a held pin is off its hook and moves freely).
  bool isGrasped(int particle) const {
    return std::any_of(grasps.begin(), grasps.end(), [particle](const Grasp& g) { return g.particle == particle; });
  }
  /// The gripper holding particle i, or nullptr.
  const Gripper* gripperHolding(int particle) const {
    for (const Gripper& gripper : grippers) {
      if (std::find(gripper.particles.begin(), gripper.particles.end(), particle) != gripper.particles.end()) {
        return &gripper;
      }
    }
    return nullptr;
  }
};

/// The ids of grasps or grippers as messages list them, "3, 7" (empty for none): a client told its grasp
/// or gripper was let go must act on it (grasp again, attach again).
template <typename Held>
std::string idList(const std::vector<Held>& held) {
  std::string list;
  for (const Held& h : held) list += (list.empty() ? "" : ", ") + std::to_string(h.id);
  return list;
}

/// The grasps or grippers of `before` whose id none of `after` has: those a change of the whole state
/// (a state file loaded) let go.
template <typename Held>
std::vector<Held> letGo(const std::vector<Held>& before, const std::vector<Held>& after) {
  std::vector<Held> gone;
  for (const Held& h : before) {
    if (std::none_of(after.begin(), after.end(), [&h](const Held& a) { return a.id == h.id; })) gone.push_back(h);
  }
  return gone;
}

}  // namespace cloth_sim::core
