#include "cloth_sim/ros/grippers.h"

#include "cloth_sim/ros/conversions.h"

#include <geometry_msgs/WrenchStamped.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

namespace cloth_sim {

namespace {

/// Seconds between repeats of a warning about a gripper.
constexpr double kWarnThrottle_s = 5.0;
/// Wrench messages a subscriber may fall behind by.
constexpr std::uint32_t kWrenchQueue = 10;

std::string particleList(const std::vector<int>& particles) {
  std::ostringstream out;
  for (std::size_t k = 0; k < particles.size(); ++k) out << (k == 0 ? "" : ", ") << particles[k];
  return out.str();
}

}  // namespace

Grippers::Grippers(ros::NodeHandle& private_handle, const FrameInputs& frames, std::string world_frame,
                   std::function<core::Simulation&()> simulation, std::function<ros::Time()> next_frame_end)
    : pnh_(private_handle),
      frames_(frames),
      world_frame_(std::move(world_frame)),
      simulation_(std::move(simulation)),
      next_frame_end_(std::move(next_frame_end)) {
  attach_srv_ = pnh_.advertiseService(kAttachService, &Grippers::onAttach, this);
  detach_srv_ = pnh_.advertiseService(kDetachService, &Grippers::onDetach, this);
}

bool Grippers::onAttach(cloth_sim::Attach::Request& request, cloth_sim::Attach::Response& response) {
  response.success = false;
  const std::string name = "gripper " + std::to_string(request.id);
  if (request.frame.empty() || request.frame[0] == '/') {
    response.message = name + ": frame '" + request.frame + "' must be a non-empty tf frame name without a leading '/'";
    return true;
  }
  if (const std::string problem = core::textLengthProblem("frame", request.frame); !problem.empty()) {
    response.message = name + ": " + problem;
    return true;
  }
  core::GripperRequest attach;
  attach.id = request.id;
  attach.frame = request.frame;
  attach.radius_m = request.radius;
  attach.max_force_N = request.max_force;
  attach.particles.assign(request.particles.begin(), request.particles.end());
  ros::Time stamp;
  std::string why;
  // Where the frame is now: the offsets the particles keep are taken in it.
  if (!frames_.poseAtOrNewest(request.frame, world_frame_, ros::Time(0), &attach.pose, &stamp, &why)) {
    response.message = name + ": unknown frame '" + request.frame + "' (tf: " + why + ")";
    return true;
  }
  // A frame that stopped being published would be called lost by the first frame after the attach (and the
  // particles held still where it was last seen): refused now, while the client can still do something. Its
  // age is taken where that frame will take it, at the next frame's end (a transform 0.49 s old now is 0.51
  // s old there), or now if that is later: while paused the next frame's end is past (the node re-anchors
  // its clock at ~pause false) unless ~step ran ahead of the clock, whose next ~step takes it there.
  const ros::Time first_look = std::max(ros::Time::now(), next_frame_end_());
  if (const std::optional<double> age_s = staleAge_s(stamp, first_look)) {
    std::ostringstream message;
    message << name << ": the newest transform of frame '" << request.frame << "' is " << *age_s
            << " s old at the next frame's end (a gripper follows a frame at most " << kFrameLostAfter_s << " s stale)";
    response.message = message.str();
    return true;
  }
  std::vector<int> held;
  std::string error;
  if (!simulation_().attachGripper(attach, &held, &error)) {
    response.message = name + ": " + error;
    return true;
  }
  follow(request.id, request.frame).last_seen = stamp;
  response.particles.assign(held.begin(), held.end());
  response.success = true;
  response.message = name + " holds " + std::to_string(held.size()) + " particles in '" + request.frame + "'";
  ROS_INFO("cloth_node: %s", response.message.c_str());
  return true;
}

bool Grippers::onDetach(cloth_sim::Detach::Request& request, cloth_sim::Detach::Response& response) {
  const std::string name = "gripper " + std::to_string(request.id);
  response.success = simulation_().detachGripper(request.id);
  held_.erase(request.id);  // closes its wrench topic
  response.message = response.success ? name + " let go" : "no " + name + " is attached";
  return true;
}

void Grippers::beforeFrame(const ros::Time& frame_end) {
  core::Simulation& simulation = simulation_();
  for (const core::Gripper& gripper : simulation.grippers()) {
    const auto entry = held_.find(gripper.id);
    if (entry == held_.end()) continue;
    Held& held = entry->second;
    core::Pose pose;
    ros::Time stamp;
    std::string why;
    if (!frames_.poseAtOrNewest(held.frame, world_frame_, frame_end, &pose, &stamp, &why)) {
      held.lost = true;
      held.lost_reason = "tf: " + why;
      continue;  // no new pose: the core holds it where it was last seen
    }
    const std::optional<double> age_s = staleAge_s(stamp, frame_end);
    held.lost = age_s.has_value();
    if (held.lost) {
      std::ostringstream reason;
      reason << "its newest transform is " << *age_s << " s old";
      held.lost_reason = reason.str();
      continue;
    }
    held.last_seen = stamp;
    std::string error;
    if (!simulation.moveGripper(gripper.id, pose, &error)) {
      held.lost = true;
      held.lost_reason = error;
    }
  }
}

void Grippers::afterFrame(const ros::Time& stamp) {
  const core::Simulation& simulation = simulation_();
  for (const core::GripperWrench& wrench : simulation.gripperWrenches()) {
    const auto entry = held_.find(wrench.id);
    if (entry == held_.end()) continue;
    Held& held = entry->second;
    if (!wrench.slipped.empty()) {
      held.slipped += wrench.slipped.size();
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: particles %s slipped out of gripper %u ('%s'): max_force exceeded",
                        particleList(wrench.slipped).c_str(), wrench.id, held.frame.c_str());
    }
    if (held.wrench.getNumSubscribers() == 0) continue;
    geometry_msgs::WrenchStamped message;
    message.header.stamp = stamp;
    message.header.frame_id = held.frame;
    message.wrench.force = toVector3(wrench.force_N);
    message.wrench.torque = toVector3(wrench.torque_N_m);
    held.wrench.publish(message);
  }
}

Grippers::Held& Grippers::follow(std::uint32_t id, const std::string& frame) {
  Held& entry = held_[id];
  entry = Held();
  entry.frame = frame;
  entry.wrench = pnh_.advertise<geometry_msgs::WrenchStamped>(kWrenchTopicPrefix + std::to_string(id) + kWrenchTopicSuffix,
                                                              kWrenchQueue);
  return entry;
}

void Grippers::synchronize() {
  const core::Simulation& simulation = simulation_();
  for (auto entry = held_.begin(); entry != held_.end();) {
    bool attached = false;
    for (const core::Gripper& gripper : simulation.grippers()) {
      attached = attached || (gripper.id == entry->first && gripper.frame == entry->second.frame);
    }
    entry = attached ? std::next(entry) : held_.erase(entry);
  }
  for (const core::Gripper& gripper : simulation.grippers()) {
    if (held_.count(gripper.id) == 0) follow(gripper.id, gripper.frame);
  }
}

void Grippers::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const core::Simulation& simulation = simulation_();
  std::string problems;
  for (const core::Gripper& gripper : simulation.grippers()) {
    const std::string name = "gripper " + std::to_string(gripper.id);
    status.add(name + " frame", gripper.frame);
    status.add(name + " particles held", gripper.particles.size());
    const auto entry = held_.find(gripper.id);
    if (entry == held_.end()) continue;
    const Held& held = entry->second;
    status.add(name + " particles slipped", held.slipped);
    if (held.lost) {
      problems += (problems.empty() ? "" : "; ") + name + ": frame '" + held.frame + "' lost (" + held.lost_reason +
                  "): its particles stay where it was last seen";
    } else if (held.slipped > 0) {
      problems += (problems.empty() ? "" : "; ") + name + ": " + std::to_string(held.slipped) +
                  " particles slipped out ('" + held.frame + "', max_force)";
    }
  }
  if (problems.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, std::to_string(simulation.grippers().size()) + " grippers");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problems);
  }
}

}  // namespace cloth_sim
