#include "cloth_sim/ros/robot_colliders.h"

#include "cloth_sim/ros/ros_time.h"

#include <urdf/model.h>

#include <set>
#include <sstream>
#include <utility>

namespace cloth_sim {

bool collidersFromUrdf(const std::string& urdf_xml, std::vector<core::FrameCollider>* colliders,
                       std::vector<std::string>* mesh_links, std::string* error) {
  urdf::Model model;
  if (!model.initString(urdf_xml)) {
    *error = "not a URDF the urdf library can read (see its error above)";
    return false;
  }
  std::set<std::string> meshes;
  for (const auto& [name, link] : model.links_) {
    if (!link) continue;
    for (const urdf::CollisionSharedPtr& collision : link->collision_array) {
      if (!collision || !collision->geometry) continue;
      core::FrameCollider collider;
      collider.frame = name;
      const urdf::Pose& origin = collision->origin;
      collider.offset_m = Eigen::Vector3d(origin.position.x, origin.position.y, origin.position.z);
      double roll = 0.0, pitch = 0.0, yaw = 0.0;
      origin.rotation.getRPY(roll, pitch, yaw);
      collider.rpy_rad = Eigen::Vector3d(roll, pitch, yaw);
      switch (collision->geometry->type) {
        case urdf::Geometry::SPHERE: {
          collider.shape = core::ShapeKind::kSphere;
          collider.radius_m = static_cast<const urdf::Sphere&>(*collision->geometry).radius;
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& cylinder = static_cast<const urdf::Cylinder&>(*collision->geometry);
          collider.shape = core::ShapeKind::kCapsule;
          collider.radius_m = cylinder.radius;
          collider.length_m = cylinder.length;
          break;
        }
        case urdf::Geometry::BOX: {
          const auto& box = static_cast<const urdf::Box&>(*collision->geometry);
          collider.shape = core::ShapeKind::kBox;
          collider.size_m = Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z);
          break;
        }
        default:
          meshes.insert(name);
          continue;
      }
      colliders->push_back(collider);
    }
  }
  mesh_links->assign(meshes.begin(), meshes.end());
  return true;
}

FrameColliderInputs::FrameColliderInputs(const FrameInputs& frames, std::string world_frame,
                                         std::function<core::Simulation&()> simulation)
    : frames_(frames), world_frame_(std::move(world_frame)), simulation_(std::move(simulation)) {}

void FrameColliderInputs::beforeFrame(const ros::Time& frame_end) {
  core::Simulation& simulation = simulation_();
  const std::vector<core::FrameCollider>& colliders = simulation.options().colliders.frames;
  problems_.assign(colliders.size(), "");
  for (std::size_t c = 0; c < colliders.size(); ++c) {
    core::Pose pose;
    ros::Time stamp;
    std::string why;
    if (!frames_.poseAtOrNewest(colliders[c].frame, world_frame_, frame_end, &pose, &stamp, &why)) {
      problems_[c] = "tf: " + why;
      continue;
    }
    if (!stamp.isZero() && secondsBetween(stamp, frame_end) > kLostAfter_s) {
      std::ostringstream reason;
      reason << "its newest transform is " << secondsBetween(stamp, frame_end) << " s old";
      problems_[c] = reason.str();
      continue;
    }
    std::string error;
    if (!simulation.moveFrameCollider(c, pose, &error)) problems_[c] = error;
  }
}

void FrameColliderInputs::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const core::Simulation& simulation = simulation_();
  const std::vector<core::FrameCollider>& colliders = simulation.options().colliders.frames;
  std::string problems;
  std::size_t posed = 0;
  for (std::size_t c = 0; c < colliders.size(); ++c) {
    if (c < simulation.frameColliders().size() && simulation.frameColliders()[c].seen) ++posed;
    if (c < problems_.size() && !problems_[c].empty()) {
      problems += (problems.empty() ? "" : "; ") + ("frame collider " + std::to_string(c) + " on '" +
                                                    colliders[c].frame + "': " + problems_[c]);
    }
  }
  status.add("frame colliders", colliders.size());
  status.add("frame colliders posed", posed);
  if (problems.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, std::to_string(colliders.size()) + " frame colliders");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problems);
  }
}

}  // namespace cloth_sim
