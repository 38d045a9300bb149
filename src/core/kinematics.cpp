#include "cloth_sim/core/kinematics.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/state.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cloth_sim::core {

namespace {

/// Exactly zero in every component (Eigen's isZero() allows 1e-12).
bool exactlyZero(const Eigen::Vector3d& v) { return (v.array() == 0.0).all(); }

/// Where a particle held at offset_m in a body at `pose` is. A particle held at the body's origin (every
/// pin on its hook) is exactly at the origin: no rounding through the rotation.
Eigen::Vector3d heldPosition(const Pose& pose, const Eigen::Vector3d& offset_m) {
  return exactlyZero(offset_m) ? pose.position_m : pose.transform(offset_m);
}

Eigen::Vector3d heldVelocity(const Pose& pose, const Twist& twist, const Eigen::Vector3d& offset_m) {
  return exactlyZero(offset_m) ? twist.linear_m_per_s : twist.pointVelocity(pose.orientation * offset_m);
}

}  // namespace

double swingPeakSpeed_m_per_s(const Eigen::Vector3d& amplitude_m, double period_s) {
  const double amplitude = amplitude_m.norm();
  return amplitude == 0.0 ? 0.0 : amplitude * kTwoPi / period_s;
}

Pose PoseTrack::at(double s) const {
  if (!(s > 0.0)) return start;
  if (s >= 1.0) return end;
  Pose pose;
  pose.position_m = start.position_m + s * (end.position_m - start.position_m);
  pose.orientation = start.orientation.slerp(s, end.orientation);
  return pose;
}

Twist PoseTrack::twist() const {
  Twist twist;
  twist.linear_m_per_s = (end.position_m - start.position_m) / duration_s;
  // The turn from start to end, world frame, the shorter way round (as slerp takes it): angle in [0, pi].
  const Eigen::AngleAxisd turn(end.orientation * start.orientation.conjugate());
  twist.angular_rad_per_s = turn.axis() * (turn.angle() / duration_s);
  return twist;
}

ScriptedMotion::TravelShare ScriptedMotion::travelShare(double time_s) const {
  if (travel_time_s <= 0.0 || time_s >= travel_time_s) return {};
  // Smoothstep s(u) = 3u^2 - 2u^3: the body leaves and arrives at rest.
  const double u = std::max(0.0, time_s / travel_time_s);
  return {1.0 - u * u * (3.0 - 2.0 * u), -6.0 * u * (1.0 - u) / travel_time_s};
}

Eigen::Vector3d ScriptedMotion::swingAt(double time_s) const {
  return swing_amplitude_m * periodicSine(time_s, swing_period_s);
}

Eigen::Vector3d ScriptedMotion::positionAt(double time_s) const {
  // The terms in the order the closed forms this replaces summed them, ((origin + drift) + swing) + travel,
  // and no drift term at all without a drift (a pin's hook had none): the same bits as those closed forms.
  const Eigen::Vector3d base_m = exactlyZero(velocity_m_per_s) ? origin_m : Eigen::Vector3d(origin_m + velocity_m_per_s * time_s);
  return base_m + swingAt(time_s) + travelShare(time_s).remaining * travel_m;
}

Eigen::Vector3d ScriptedMotion::velocityAt(double time_s) const {
  const Eigen::Vector3d swing_m_per_s = swing_amplitude_m * periodicSineRate(time_s, swing_period_s);
  const Eigen::Vector3d moving_m_per_s =
      exactlyZero(velocity_m_per_s) ? swing_m_per_s : Eigen::Vector3d(velocity_m_per_s + swing_m_per_s);
  return moving_m_per_s + travelShare(time_s).rate_per_s * travel_m;
}

double ScriptedMotion::peakSpeed_m_per_s(double from_time_s) const {
  double speed_m_per_s = velocity_m_per_s.norm() + swingPeakSpeed_m_per_s(swing_amplitude_m, swing_period_s);
  if (travel_time_s > 0.0 && from_time_s < travel_time_s) {
    speed_m_per_s += kSmoothstepPeakRate * travel_m.norm() / travel_time_s;
  }
  return speed_m_per_s;
}

bool isFinitePose(const Pose& pose, double max_reach_m) {
  return pose.position_m.allFinite() && pose.position_m.norm() <= max_reach_m && pose.orientation.coeffs().allFinite() &&
         std::abs(pose.orientation.norm() - 1.0) <= kUnitQuaternionTolerance;
}

Pose Body::poseAt(double time_s) const {
  if (const auto* scripted = std::get_if<ScriptedMotion>(&motion)) {
    Pose pose;
    pose.position_m = scripted->positionAt(time_s);
    return pose;
  }
  return std::get<PoseTrack>(motion).atTime(time_s);
}

Twist Body::twistAt(double time_s) const {
  if (const auto* scripted = std::get_if<ScriptedMotion>(&motion)) {
    Twist twist;
    twist.linear_m_per_s = scripted->velocityAt(time_s);
    return twist;
  }
  return std::get<PoseTrack>(motion).twist();
}

double Body::peakSpeed_m_per_s(double time_s) const {
  if (const auto* scripted = std::get_if<ScriptedMotion>(&motion)) return scripted->peakSpeed_m_per_s(time_s);
  return std::get<PoseTrack>(motion).twist().linear_m_per_s.norm();
}

std::size_t Kinematics::addBody(Body body) {
  bodies_.push_back(std::move(body));
  return bodies_.size() - 1;
}

void Kinematics::attach(Attachment attachment) {
  if (attachment.body >= bodies_.size() ||
      attachment.offsets_m.cols() != static_cast<Eigen::Index>(attachment.particles.size())) {
    throw std::invalid_argument("attachment: unknown body or one offset per particle missing");
  }
  attachments_.push_back(std::move(attachment));
}

void Kinematics::clear() {
  bodies_.clear();
  attachments_.clear();
  sphere_bodies_.clear();
  frame_collider_bodies_.clear();
}

ScriptedMotion Kinematics::hookMotion(const SceneOptions& options, const ClothInputs& inputs, std::size_t pin) {
  ScriptedMotion hook;
  hook.origin_m = inputs.pin_anchors_m.col(static_cast<Eigen::Index>(pin));
  hook.swing_amplitude_m = options.pin_motion_amplitude_m;
  hook.swing_period_s = options.pin_motion_period_s;
  hook.travel_m = inputs.pin_travel_m.col(static_cast<Eigen::Index>(pin));
  hook.travel_time_s = options.pin_travel_time_s;
  return hook;
}

void Kinematics::setScene(const SceneOptions& options, const ClothInputs& inputs) {
  clear();
  for (std::size_t p = 0; p < inputs.pins.size(); ++p) {
    const int particle = inputs.pins[p];
    if (inputs.isGrasped(particle)) continue;  // a held pin is off its hook and moves freely
    const std::size_t body = addBody({"pin " + std::to_string(particle), hookMotion(options, inputs, p)});
    attach({body, {particle}, Eigen::Matrix3Xd::Zero(3, 1)});
  }
  for (std::size_t s = 0; s < options.colliders.spheres.size(); ++s) {
    sphere_bodies_.push_back(addBody({"sphere " + std::to_string(s), options.colliders.spheres[s].motion()}));
  }
  for (const Gripper& gripper : inputs.grippers) {
    if (gripper.particles.empty()) continue;  // every particle slipped out: nothing left to carry
    const std::size_t body =
        addBody({"gripper " + std::to_string(gripper.id) + " (" + gripper.frame + ")", gripper.track});
    attach({body, gripper.particles, gripper.offsets_m});
  }
  for (std::size_t c = 0; c < inputs.frame_colliders.size() && c < options.colliders.frames.size(); ++c) {
    if (!inputs.frame_colliders[c].seen) continue;
    const std::size_t body = addBody(
        {"frame collider " + std::to_string(c) + " (" + options.colliders.frames[c].frame + ")", inputs.frame_colliders[c].track});
    frame_collider_bodies_.emplace_back(c, body);
  }
}

void Kinematics::maskConstrained(Eigen::VectorXd& inverse_mass_per_kg) const {
  for (const Attachment& attachment : attachments_) {
    for (const int particle : attachment.particles) inverse_mass_per_kg[particle] = 0.0;
  }
}

void Kinematics::prescribedPositions(double time_s, Eigen::Matrix3Xd& positions_m) const {
  for (const Attachment& attachment : attachments_) {
    const Pose pose = bodies_[attachment.body].poseAt(time_s);
    for (std::size_t k = 0; k < attachment.particles.size(); ++k) {
      positions_m.col(attachment.particles[k]) = heldPosition(pose, attachment.offsets_m.col(static_cast<Eigen::Index>(k)));
    }
  }
}

void Kinematics::enforce(double time_s, ClothState& state) const {
  prescribedPositions(time_s, state.positions_m);
  for (const Attachment& attachment : attachments_) {
    const Body& body = bodies_[attachment.body];
    const Pose pose = body.poseAt(time_s);
    const Twist twist = body.twistAt(time_s);
    for (std::size_t k = 0; k < attachment.particles.size(); ++k) {
      state.velocities_m_per_s.col(attachment.particles[k]) =
          heldVelocity(pose, twist, attachment.offsets_m.col(static_cast<Eigen::Index>(k)));
    }
  }
}

double Kinematics::peakSpeed_m_per_s(std::size_t body, double time_s) const {
  const Body& moving = bodies_[body];
  const double origin_speed_m_per_s = moving.peakSpeed_m_per_s(time_s);
  const auto* track = std::get_if<PoseTrack>(&moving.motion);
  if (track == nullptr) return origin_speed_m_per_s;  // scripted bodies translate: every point moves alike
  const double turn_rad_per_s = track->twist().angular_rad_per_s.norm();
  double lever_m = 0.0;
  for (const Attachment& attachment : attachments_) {
    if (attachment.body != body || attachment.offsets_m.cols() == 0) continue;
    lever_m = std::max(lever_m, attachment.offsets_m.colwise().norm().maxCoeff());
  }
  return origin_speed_m_per_s + turn_rad_per_s * lever_m;
}

int Kinematics::heldParticles(std::size_t body) const {
  int held = 0;
  for (const Attachment& attachment : attachments_) {
    if (attachment.body == body) held += static_cast<int>(attachment.particles.size());
  }
  return held;
}

}  // namespace cloth_sim::core
