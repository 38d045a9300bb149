#include "cloth_sim/ros/robot_colliders.h"

#include "cloth_sim/core/options.h"

#include <tinyxml2.h>
#include <urdf/model.h>

#include <map>
#include <set>
#include <optional>
#include <sstream>
#include <utility>

namespace cloth_sim {

namespace {

/// How many `<collision>` elements each `<link>` of the URDF's XML has (links without one left out).
std::map<std::string, std::size_t> collisionElementsPerLink(const std::string& urdf_xml) {
  std::map<std::string, std::size_t> counts;
  tinyxml2::XMLDocument document;
  if (document.Parse(urdf_xml.c_str()) != tinyxml2::XML_SUCCESS) return counts;
  const tinyxml2::XMLElement* robot = document.FirstChildElement("robot");
  if (robot == nullptr) return counts;
  for (const tinyxml2::XMLElement* link = robot->FirstChildElement("link"); link != nullptr;
       link = link->NextSiblingElement("link")) {
    const char* name = link->Attribute("name");
    std::size_t count = 0;
    for (const tinyxml2::XMLElement* collision = link->FirstChildElement("collision"); collision != nullptr;
         collision = collision->NextSiblingElement("collision")) {
      ++count;
    }
    if (name != nullptr && count > 0) counts[name] += count;
  }
  return counts;
}

/// Why the collider of `link`'s collision `index` is out of the scenes' ranges, or "": the core's own checks
/// of one frame collider, named by the link instead of an index into frame_colliders.
std::string urdfColliderProblem(const core::FrameCollider& collider, const std::string& link, std::size_t index) {
  std::string problems;
  for (const std::string& problem : core::validateFrameCollider(collider)) {
    problems += (problems.empty() ? "" : "; ") + problem;
  }
  if (problems.empty()) return "";
  return "URDF link '" + link + "' collision " + std::to_string(index) + ": " + problems;
}

}  // namespace

bool collidersFromUrdf(const std::string& urdf_xml, std::vector<core::FrameCollider>* colliders,
                       std::vector<std::string>* mesh_links, std::string* error) {
  urdf::Model model;
  if (!model.initString(urdf_xml)) {
    *error = "not a URDF the urdf library can read (see its error above)";
    return false;
  }
  // urdfdom drops a <collision> it cannot read (a box with two sizes, a cylinder without a length, no
  // <geometry>) with an ERROR line and reads on: a robot would then run with fewer links than it has.
  std::string dropped;
  for (const auto& [name, count] : collisionElementsPerLink(urdf_xml)) {
    const auto link = model.links_.find(name);
    std::size_t parsed = 0;
    if (link != model.links_.end() && link->second) {
      for (const urdf::CollisionSharedPtr& collision : link->second->collision_array) {
        if (collision && collision->geometry) ++parsed;
      }
    }
    if (parsed < count) {
      dropped += (dropped.empty() ? "" : ", ") + ("'" + name + "' (" + std::to_string(count - parsed) + " of " +
                                                   std::to_string(count) + ")");
    }
  }
  if (!dropped.empty()) {
    *error = "the urdf library could not read the <collision> elements of links " + dropped +
             " (see its errors above: a bad <collision>, or an <inertial> or <visual> before it, which ends "
             "the link's parsing): fix them, or the robot would collide without them";
    return false;
  }
  std::set<std::string> meshes;
  std::string problems;
  for (const auto& [name, link] : model.links_) {
    if (!link) continue;
    for (std::size_t index = 0; index < link->collision_array.size(); ++index) {
      const urdf::CollisionSharedPtr& collision = link->collision_array[index];
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
      const std::string problem = urdfColliderProblem(collider, name, index);
      if (!problem.empty()) problems += (problems.empty() ? "" : "; ") + problem;
      colliders->push_back(collider);
    }
  }
  if (!problems.empty()) {
    *error = problems;
    return false;
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
    if (const std::optional<double> age_s = staleAge_s(stamp, frame_end)) {
      std::ostringstream reason;
      reason << "its newest transform is " << *age_s << " s old";
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
