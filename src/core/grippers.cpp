#include "cloth_sim/core/grippers.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace cloth_sim::core {

std::vector<int> particlesWithin(const Eigen::Matrix3Xd& positions_m, const Eigen::Vector3d& center_m, double radius_m) {
  std::vector<int> inside;
  const double radius_sq = radius_m * radius_m;
  for (Eigen::Index i = 0; i < positions_m.cols(); ++i) {
    if ((positions_m.col(i) - center_m).squaredNorm() <= radius_sq) inside.push_back(static_cast<int>(i));
  }
  return inside;
}

Eigen::Matrix3Xd offsetsInFrame(const Eigen::Matrix3Xd& positions_m, const std::vector<int>& particles, const Pose& pose) {
  Eigen::Matrix3Xd offsets(3, static_cast<Eigen::Index>(particles.size()));
  const Eigen::Matrix3d to_frame = pose.orientation.toRotationMatrix().transpose();
  for (std::size_t k = 0; k < particles.size(); ++k) {
    offsets.col(static_cast<Eigen::Index>(k)) = to_frame * (positions_m.col(particles[k]) - pose.position_m);
  }
  return offsets;
}

void holdStill(Gripper& gripper, double time_s, double frame_s) {
  gripper.track.start = gripper.track.end;
  gripper.track.start_time_s = time_s;
  gripper.track.duration_s = frame_s;
}

void moveTrack(Gripper& gripper, const Pose& end, double time_s, double frame_s, double max_travel_m) {
  holdStill(gripper, time_s, frame_s);
  const Pose& start = gripper.track.start;
  Pose target = end;
  const Eigen::Vector3d travel_m = end.position_m - start.position_m;
  const double distance_m = travel_m.norm();
  // How far the origin and each held particle (o + R offset) would go in this frame, and the lever of the
  // farthest one.
  const Eigen::Matrix3d turn = end.orientation.toRotationMatrix() - start.orientation.toRotationMatrix();
  double farthest_m = distance_m;
  double lever_m = 0.0;
  for (Eigen::Index k = 0; k < gripper.offsets_m.cols(); ++k) {
    farthest_m = std::max(farthest_m, (travel_m + turn * gripper.offsets_m.col(k)).norm());
    lever_m = std::max(lever_m, gripper.offsets_m.col(k).norm());
  }
  if (farthest_m > max_travel_m) {
    // Catch up along the straight line and the shorter turn, in the share of the pose change that keeps
    // the origin and every held particle within max_travel_m: at share s a particle at lever r is at most
    // s |travel| + r s angle away (the chord of its arc is shorter than the arc).
    const double angle_rad = start.orientation.angularDistance(end.orientation);
    const double share = std::min(1.0, max_travel_m / (distance_m + angle_rad * lever_m));
    target.position_m = start.position_m + share * travel_m;
    target.orientation = start.orientation.slerp(share, end.orientation);
  }
  gripper.track.end = target;
}

GripperWrench gripperWrench(const Gripper& gripper, const Pose& pose, const Eigen::Matrix3Xd& positions_m,
                            const Eigen::Matrix3Xd& forces_N, const Eigen::VectorXd& mass_kg,
                            const Eigen::Matrix3Xd& accelerations_m_per_s2) {
  GripperWrench wrench;
  wrench.id = gripper.id;
  Eigen::Vector3d force_N = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque_N_m = Eigen::Vector3d::Zero();
  for (const int particle : gripper.particles) {
    // -R_i: what particle i, and through it the cloth, pulls on the gripper with.
    const Eigen::Vector3d pull_N = forces_N.col(particle) - mass_kg[particle] * accelerations_m_per_s2.col(particle);
    force_N += pull_N;
    torque_N_m += (positions_m.col(particle) - pose.position_m).cross(pull_N);
    if (gripper.max_force_N > 0.0 && pull_N.norm() > gripper.max_force_N) wrench.slipped.push_back(particle);
  }
  const Eigen::Matrix3d to_frame = pose.orientation.toRotationMatrix().transpose();
  wrench.force_N = to_frame * force_N;
  wrench.torque_N_m = to_frame * torque_N_m;
  return wrench;
}

void letSlip(Gripper& gripper, const std::vector<int>& slipped) {
  std::vector<int> kept;
  std::vector<Eigen::Index> kept_columns;
  for (std::size_t k = 0; k < gripper.particles.size(); ++k) {
    if (std::find(slipped.begin(), slipped.end(), gripper.particles[k]) != slipped.end()) continue;
    kept.push_back(gripper.particles[k]);
    kept_columns.push_back(static_cast<Eigen::Index>(k));
  }
  Eigen::Matrix3Xd offsets(3, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t k = 0; k < kept_columns.size(); ++k) {
    offsets.col(static_cast<Eigen::Index>(k)) = gripper.offsets_m.col(kept_columns[k]);
  }
  gripper.particles = std::move(kept);
  gripper.offsets_m = std::move(offsets);
}

std::string checkGrippers(const std::vector<Gripper>& grippers, const std::vector<int>& pins, int particles,
                          std::size_t max_grippers, double max_reach_m) {
  if (grippers.size() > max_grippers) {
    return std::to_string(grippers.size()) + " grippers: at most " + std::to_string(max_grippers);
  }
  std::set<std::uint32_t> ids;
  std::set<int> held;
  for (const Gripper& gripper : grippers) {
    const std::string name = "gripper " + std::to_string(gripper.id);
    if (!ids.insert(gripper.id).second) return name + " appears twice: ids must be unique";
    if (static_cast<Eigen::Index>(gripper.particles.size()) != gripper.offsets_m.cols()) {
      return name + ": " + std::to_string(gripper.particles.size()) + " particles but " +
             std::to_string(gripper.offsets_m.cols()) + " offsets";
    }
    for (const int particle : gripper.particles) {
      if (particle < 0 || particle >= particles) {
        return name + " particle " + std::to_string(particle) + " is outside [0, " + std::to_string(particles - 1) + "]";
      }
      if (std::binary_search(pins.begin(), pins.end(), particle)) {
        return name + " particle " + std::to_string(particle) + " is pinned";
      }
      if (!held.insert(particle).second) return name + " particle " + std::to_string(particle) + " is held twice";
    }
    if (!gripper.offsets_m.allFinite() || (gripper.offsets_m.size() > 0 && gripper.offsets_m.cwiseAbs().maxCoeff() > max_reach_m)) {
      return name + " offsets: must be finite and within " + std::to_string(max_reach_m) + " m";
    }
    if (!isFinitePose(gripper.track.start, max_reach_m) || !isFinitePose(gripper.track.end, max_reach_m)) {
      return name + " pose: must be finite, within " + std::to_string(max_reach_m) + " m, with a unit quaternion";
    }
    if (!(gripper.track.duration_s > 0.0) || !std::isfinite(gripper.track.duration_s) ||
        !std::isfinite(gripper.track.start_time_s)) {
      return name + " track: its time and duration must be finite, the duration > 0";
    }
    if (!(gripper.max_force_N >= 0.0) || !std::isfinite(gripper.max_force_N)) {
      return name + " max_force " + std::to_string(gripper.max_force_N) + " N: must be finite and >= 0";
    }
  }
  return "";
}

}  // namespace cloth_sim::core
