// Grippers (issue 14): particles held rigidly in a moving frame, and what the cloth does to that frame.
// Stateless kernels over the flat per-particle arrays; Simulation owns the grippers (in ClothInputs) and
// calls these. Frames: positions and forces are in the simulation's world frame; offsets and the
// reported wrench are in the gripper's own frame.
#pragma once

#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/kinematics.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// The particles within radius_m of pose's origin (world frame), in index order.
std::vector<int> particlesWithin(const Eigen::Matrix3Xd& positions_m, const Eigen::Vector3d& center_m, double radius_m);

/// Each particle's place in the frame `pose` (3 x particles.size(), m): p_local = R^T (x - o).
Eigen::Matrix3Xd offsetsInFrame(const Eigen::Matrix3Xd& positions_m, const std::vector<int>& particles, const Pose& pose);

/// The gripper held still at its last pose from time_s on (a frame with no new pose from tf).
void holdStill(Gripper& gripper, double time_s, double frame_s);

/// Starts the gripper's next frame at time_s: from where its track ended to `end`, over frame_s. The
/// origin and every held particle move at most max_travel_m in one frame: a frame that reappears far away
/// or turned (tf lost it for a while) is followed over several frames rather than in one leap that would
/// tear the cloth. A pose change within the limit is taken whole.
void moveTrack(Gripper& gripper, const Pose& end, double time_s, double frame_s, double max_travel_m);

/// What the cloth does to one gripper over the last frame.
struct GripperWrench {
  std::uint32_t id = 0;
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();      ///< on the gripper, in its frame
  Eigen::Vector3d torque_N_m = Eigen::Vector3d::Zero();   ///< about its frame's origin, in its frame
  std::vector<int> slipped;  ///< particles that slipped out this frame (max_force_N exceeded)
};

/// The wrench the cloth exerts on `gripper` at its pose `pose`. A held particle i obeys
///   m_i a_i = F_i + R_i
/// where F_i is every force the model puts on it (springs, gravity, air, wind; a grasp of a held particle
/// does not act, ClothForceModel::graspActs) and R_i the constraint's reaction, the force the gripper
/// applies. The cloth pushes back with -R_i = F_i - m_i a_i,
/// so the force on the gripper is the sum of F_i - m_i a_i over its particles, and the torque the sum of
/// (x_i - o) x (F_i - m_i a_i). forces_N are F at the state positions_m (the end of the frame), and
/// accelerations_m_per_s2 the held particles' accelerations over the last step (both world frame).
/// Particles whose |R_i| exceeds max_force_N (if > 0) are listed in `slipped` (their reaction still counts:
/// they slip after this frame).
GripperWrench gripperWrench(const Gripper& gripper, const Pose& pose, const Eigen::Matrix3Xd& positions_m,
                            const Eigen::Matrix3Xd& forces_N, const Eigen::VectorXd& mass_kg,
                            const Eigen::Matrix3Xd& accelerations_m_per_s2);

/// Removes the listed particles from the gripper (with their offsets).
void letSlip(Gripper& gripper, const std::vector<int>& slipped);

/// Why these grippers cannot be restored onto a cloth of `particles` particles with these pins, or "":
/// at most max_grippers, ids unique, particles in range, held once, not pinned, offsets and poses finite
/// and within max_reach_m, a unit orientation, a positive frame, max_force_N finite and >= 0.
std::string checkGrippers(const std::vector<Gripper>& grippers, const std::vector<int>& pins, int particles,
                          std::size_t max_grippers, double max_reach_m);

}  // namespace cloth_sim::core
