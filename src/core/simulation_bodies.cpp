// Simulation's bodies that move the cloth by prescription or hold it: grasps (the paper's grab force
// and the hooks of pinned particles), grippers on tf frames with their wrenches, and the frame colliders
// (robot links) posed each frame. The frame loop is in simulation.cpp; these change inputs_ between
// frames and keep the force model's constraints in step with them.
#include "cloth_sim/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace cloth_sim::core {

std::string Simulation::graspValuesProblem(const Eigen::Vector3d& target_m, double stiffness_N_per_m,
                                           const Eigen::Vector3d& extra_force_N) {
  if (!target_m.allFinite() || target_m.norm() > kMaxGraspReach_m) {
    return "target " + vectorText(target_m) + " m: must be finite and within " + std::to_string(kMaxGraspReach_m) +
           " m of the origin";
  }
  if (!(stiffness_N_per_m >= 0.0 && stiffness_N_per_m <= OptionLimits::kMaxStiffnessN_per_m)) {
    return "stiffness " + std::to_string(stiffness_N_per_m) + " N/m: must be in [0, " +
           std::to_string(OptionLimits::kMaxStiffnessN_per_m) + "]";
  }
  if (!extra_force_N.allFinite() || extra_force_N.norm() > kMaxGraspForce_N) {
    return "force " + vectorText(extra_force_N) + " N: must be finite and at most " +
           std::to_string(kMaxGraspForce_N) + " N";
  }
  return "";
}

bool Simulation::grab(const GraspRequest& request, std::string* error) {
  const int count = grid_.particleCount();
  const std::string problem = graspValuesProblem(request.target_m, request.stiffness_N_per_m, request.extra_force_N);
  if (!problem.empty()) {
    *error = "grasp " + problem;
    return false;
  }
  if (request.particle < -1 || request.particle >= count) {
    *error = "grasp particle " + std::to_string(request.particle) + " is outside [-1, " + std::to_string(count - 1) + "]";
    return false;
  }
  if (request.particle >= 0 && !grid_.isActive(request.particle)) {
    *error = "grasp particle " + std::to_string(request.particle) + " is outside the cloth's outline";
    return false;
  }
  const double stiffness =
      request.stiffness_N_per_m > 0.0 ? request.stiffness_N_per_m : options_.grasp_stiffness_N_per_m;
  for (Grasp& grasp : inputs_.grasps) {
    if (grasp.id != request.id) continue;
    grasp.target_m = request.target_m;  // dragging: the held particle stays the same
    grasp.stiffness_N_per_m = stiffness;
    grasp.extra_force_N = request.extra_force_N;
    bound_stale_ = true;
  energy_cache_valid_ = false;
    return true;
  }
  if (inputs_.grasps.size() >= kMaxGrasps) {
    *error = "already " + std::to_string(kMaxGrasps) + " grasps held: release one first";
    return false;
  }
  Grasp grasp;
  grasp.id = request.id;
  grasp.particle = request.particle >= 0 ? request.particle : nearestParticle(request.target_m);
  grasp.target_m = request.target_m;
  grasp.stiffness_N_per_m = stiffness;
  grasp.damping_N_s_per_m = options_.grasp_damping_N_s_per_m;
  grasp.extra_force_N = request.extra_force_N;
  // A held pin comes off its hook (paper: pins move only when grasped or driven); release() re-hooks it.
  inputs_.grasps.push_back(grasp);
  bound_stale_ = true;
  energy_cache_valid_ = false;
  force_model_.refreshConstraints();
  return true;
}

bool Simulation::attachGripper(const GripperRequest& request, std::vector<int>* held, std::string* error) {
  const std::string name = "gripper " + std::to_string(request.id);
  const int count = grid_.particleCount();
  for (const Gripper& gripper : inputs_.grippers) {
    if (gripper.id == request.id) {
      *error = name + " is already attached (to '" + gripper.frame + "'): detach it first or use another id";
      return false;
    }
  }
  if (inputs_.grippers.size() >= kMaxGrippers) {
    *error = "already " + std::to_string(kMaxGrippers) + " grippers attached: detach one first";
    return false;
  }
  if (!request.pose.position_m.allFinite() || request.pose.position_m.norm() > kMaxGraspReach_m ||
      !request.pose.orientation.coeffs().allFinite() || request.pose.orientation.norm() == 0.0) {
    *error = "frame '" + request.frame + "' has a non-finite pose or one beyond " + std::to_string(kMaxGraspReach_m) +
             " m of the origin";
    return false;
  }
  if (!std::isfinite(request.radius_m) || request.radius_m < 0.0) {
    *error = "radius " + std::to_string(request.radius_m) + " m: must be finite and >= 0";
    return false;
  }
  if (!std::isfinite(request.max_force_N) || request.max_force_N < 0.0) {
    *error = "max_force " + std::to_string(request.max_force_N) + " N: must be finite and >= 0 (0: never slips)";
    return false;
  }
  Pose pose = request.pose;
  pose.orientation.normalize();
  std::vector<int> particles = request.particles;
  if (particles.empty()) {
    if (request.radius_m <= 0.0) {
      *error = "give particles or a radius > 0";
      return false;
    }
    particles = particlesWithin(state_.positions_m, pose.position_m, request.radius_m);
    particles.erase(std::remove_if(particles.begin(), particles.end(), [&](int p) { return !grid_.isActive(p); }),
                    particles.end());  // outside the outline: not cloth
    if (particles.empty()) {
      const int nearest = nearestParticle(pose.position_m);
      *error = "radius " + std::to_string(request.radius_m) + " m around '" + request.frame +
               "' catches no particle (the nearest, " + std::to_string(nearest) + ", is " +
               std::to_string((state_.positions_m.col(nearest) - pose.position_m).norm()) + " m away)";
      return false;
    }
  }
  for (std::size_t k = 0; k < particles.size(); ++k) {
    const int particle = particles[k];
    if (particle < 0 || particle >= count) {
      *error = "particle " + std::to_string(particle) + " is outside [0, " + std::to_string(count - 1) + "]";
      return false;
    }
    if (std::find(particles.begin(), particles.begin() + static_cast<std::ptrdiff_t>(k), particle) !=
        particles.begin() + static_cast<std::ptrdiff_t>(k)) {
      *error = "particle " + std::to_string(particle) + " is listed twice";
      return false;
    }
    if (!grid_.isActive(particle)) {
      *error = "particle " + std::to_string(particle) + " is outside the cloth's outline";
      return false;
    }
    if (std::binary_search(inputs_.pins.begin(), inputs_.pins.end(), particle)) {
      // A grasp takes a pin off its hook: then the grasp, not the pin, holds it.
      const auto grasp = std::find_if(inputs_.grasps.begin(), inputs_.grasps.end(),
                                      [particle](const Grasp& g) { return g.particle == particle; });
      *error = "particle " + std::to_string(particle) + " is already held by " +
               (grasp == inputs_.grasps.end() ? std::string("its pin")
                                              : "grasp " + std::to_string(grasp->id) + " (a pinned particle, off its pin)");
      return false;
    }
    if (const Gripper* other = inputs_.gripperHolding(particle)) {
      *error = "particle " + std::to_string(particle) + " is already held by gripper " + std::to_string(other->id) +
               " ('" + other->frame + "')";
      return false;
    }
  }
  Gripper gripper;
  gripper.id = request.id;
  gripper.frame = request.frame;
  gripper.particles = particles;
  gripper.offsets_m = offsetsInFrame(state_.positions_m, particles, pose);
  gripper.max_force_N = request.max_force_N;
  gripper.track.start = pose;
  gripper.track.end = pose;
  gripper.track.start_time_s = state_.time_s;
  gripper.track.duration_s = options_.frameDuration_s();
  inputs_.grippers.push_back(std::move(gripper));
  bound_stale_ = true;
  energy_cache_valid_ = false;
  force_model_.refreshConstraints();
  // The particles take the frame's velocity (at rest until it moves): a hard constraint from now on.
  force_model_.enforceConstraints(state_.time_s, state_);
  *held = std::move(particles);
  return true;
}

bool Simulation::detachGripper(std::uint32_t id) {
  std::vector<Gripper>& grippers = inputs_.grippers;
  const auto gripper = std::find_if(grippers.begin(), grippers.end(), [id](const Gripper& g) { return g.id == id; });
  if (gripper == grippers.end()) return false;
  const auto index = gripper - grippers.begin();
  grippers.erase(gripper);
  if (index < static_cast<std::ptrdiff_t>(gripper_wrenches_.size())) gripper_wrenches_.erase(gripper_wrenches_.begin() + index);
  bound_stale_ = true;
  energy_cache_valid_ = false;
  force_model_.refreshConstraints();
  return true;
}

bool Simulation::moveGripper(std::uint32_t id, const Pose& end, std::string* error) {
  for (Gripper& gripper : inputs_.grippers) {
    if (gripper.id != id) continue;
    if (!end.position_m.allFinite() || end.position_m.norm() > kMaxGraspReach_m || !end.orientation.coeffs().allFinite() ||
        end.orientation.norm() == 0.0) {
      *error = "gripper " + std::to_string(id) + ": the pose of '" + gripper.frame +
               "' is non-finite or beyond " + std::to_string(kMaxGraspReach_m) + " m of the origin";
      return false;
    }
    Pose unit = end;
    unit.orientation.normalize();
    const double frame_s = options_.frameDuration_s();
    moveTrack(gripper, unit, state_.time_s, frame_s, kMaxGripperSpeed_m_per_s * frame_s);
    force_model_.refreshConstraints();
    return true;
  }
  *error = "no gripper " + std::to_string(id) + " is attached";
  return false;
}

bool Simulation::moveFrameCollider(std::size_t index, const Pose& frame, std::string* error) {
  if (index >= inputs_.frame_colliders.size()) {
    *error = "frame collider " + std::to_string(index) + " does not exist (the scene has " +
             std::to_string(inputs_.frame_colliders.size()) + ")";
    return false;
  }
  const FrameCollider& collider = options_.colliders.frames[index];
  if (!frame.position_m.allFinite() || frame.position_m.norm() > OptionLimits::kMaxCoordinate_m ||
      !frame.orientation.coeffs().allFinite() || frame.orientation.norm() == 0.0) {
    *error = "frame collider " + std::to_string(index) + ": the pose of '" + collider.frame +
             "' is non-finite or beyond " + std::to_string(OptionLimits::kMaxCoordinate_m) + " m of the origin";
    return false;
  }
  Pose unit = frame;
  unit.orientation.normalize();
  const Pose offset = collider.offsetPose();
  Pose shape;
  shape.position_m = unit.transform(offset.position_m);
  shape.orientation = (unit.orientation * offset.orientation).normalized();
  FrameColliderTrack& entry = inputs_.frame_colliders[index];
  entry.track.start = entry.seen ? entry.track.end : shape;  // first seen: placed, not swept in from nowhere
  entry.track.end = shape;
  entry.track.start_time_s = state_.time_s;
  entry.track.duration_s = options_.frameDuration_s();
  entry.seen = true;
  force_model_.refreshConstraints();
  return true;
}

void Simulation::holdUnmovedBodies() {
  bool changed = false;
  for (FrameColliderTrack& entry : inputs_.frame_colliders) {
    if (!entry.seen || (entry.track.start_time_s == state_.time_s && entry.track.duration_s == options_.frameDuration_s())) {
      continue;
    }
    entry.track.start = entry.track.end;
    entry.track.start_time_s = state_.time_s;
    entry.track.duration_s = options_.frameDuration_s();
    changed = true;
  }
  for (Gripper& gripper : inputs_.grippers) {
    if (gripper.track.start_time_s == state_.time_s && gripper.track.duration_s == options_.frameDuration_s()) continue;
    holdStill(gripper, state_.time_s, options_.frameDuration_s());
    changed = true;
  }
  if (changed) force_model_.refreshConstraints();
}

void Simulation::measureGripperWrenches() {
  gripper_forces_N_.resize(3, state_.positions_m.cols());
  force_model_.forces(state_.positions_m, state_.velocities_m_per_s, state_.time_s, gripper_forces_N_);
  // The held particles' acceleration over the last substep (the step that ended where they are now).
  const Eigen::Matrix3Xd accelerations_m_per_s2 =
      last_step_s_ > 0.0 && last_step_start_velocities_m_per_s_.cols() == state_.velocities_m_per_s.cols()
          ? Eigen::Matrix3Xd((state_.velocities_m_per_s - last_step_start_velocities_m_per_s_) / last_step_s_)
          : Eigen::Matrix3Xd(Eigen::Matrix3Xd::Zero(3, state_.velocities_m_per_s.cols()));
  gripper_wrenches_.clear();
  bool slipped = false;
  for (Gripper& gripper : inputs_.grippers) {
    gripper_wrenches_.push_back(gripperWrench(gripper, gripper.track.end, state_.positions_m, gripper_forces_N_, mass_kg_,
                                              accelerations_m_per_s2));
    if (!gripper_wrenches_.back().slipped.empty()) {
      letSlip(gripper, gripper_wrenches_.back().slipped);
      slipped = true;
    }
  }
  if (slipped) {
    bound_stale_ = true;
    energy_cache_valid_ = false;
    force_model_.refreshConstraints();
  }
}

bool Simulation::release(std::uint32_t id) {
  std::vector<Grasp>& grasps = inputs_.grasps;
  const auto held = std::find_if(grasps.begin(), grasps.end(), [id](const Grasp& g) { return g.id == id; });
  if (held == grasps.end()) return false;
  const int particle = held->particle;
  grasps.erase(held);
  bound_stale_ = true;
  energy_cache_valid_ = false;
  const auto pin = std::lower_bound(inputs_.pins.begin(), inputs_.pins.end(), particle);
  if (!inputs_.isGrasped(particle) && pin != inputs_.pins.end() && *pin == particle) {
    // Hang it on a hook where the hand let go: the pin's motion continues from there.
    const auto p = pin - inputs_.pins.begin();
    inputs_.pin_anchors_m.col(p) =
        state_.positions_m.col(particle) - Kinematics::hookMotion(options_, inputs_, p).swingAt(state_.time_s);
    inputs_.pin_travel_m.col(p).setZero();
    force_model_.refreshConstraints();
    force_model_.enforceConstraints(state_.time_s, state_);
  }
  return true;
}

int Simulation::nearestParticle(const Eigen::Vector3d& point_m) const {
  int nearest = 0;
  double best_m2 = std::numeric_limits<double>::infinity();
  for (int i = 0; i < state_.particleCount(); ++i) {
    if (!grid_.isActive(i)) continue;  // outside the outline: not part of the cloth
    const double d2 = (state_.positions_m.col(i) - point_m).squaredNorm();
    if (d2 < best_m2) {
      best_m2 = d2;
      nearest = i;
    }
  }
  return nearest;
}

std::vector<Eigen::Vector3d> Simulation::sphereCenters() const {
  std::vector<Eigen::Vector3d> centers;
  centers.reserve(options_.colliders.spheres.size());
  for (const SphereCollider& sphere : options_.colliders.spheres) centers.push_back(sphere.centerAt(state_.time_s));
  return centers;
}

}  // namespace cloth_sim::core
