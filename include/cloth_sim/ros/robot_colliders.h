// Robot links as colliders (issue 14 §4): the frame colliders' tf frames looked up at each frame's time
// and handed to the core, and a URDF's collision shapes turned into frame colliders (parsed with ROS's
// urdf library). The node never re-broadcasts these frames: the robot's own publishers own them.
#pragma once

#include "cloth_sim/core/simulation.h"
#include "cloth_sim/ros/frame_inputs.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/time.h>

#include <functional>
#include <string>
#include <vector>

namespace cloth_sim {

/// Every `<collision>` of every link of the URDF as a collider on that link's tf frame, at the collision
/// element's origin: a sphere as a sphere, a box as a box, a cylinder as the capsule of the same radius and
/// length (its axis is the element's z axis, as a URDF cylinder's is; the capsule reaches `radius` beyond
/// each flat end). Links whose collision is a mesh are skipped and named in *mesh_links. False with *error
/// if the text is not a URDF urdf::Model reads, if it read fewer collisions of a link than the XML has
/// `<collision>` elements (urdfdom drops a malformed one and reads on; the links are named), or if a
/// shape is out of the frame colliders' ranges ("URDF link 'arm' collision 0: radius = 0: ...").
bool collidersFromUrdf(const std::string& urdf_xml, std::vector<core::FrameCollider>* colliders,
                       std::vector<std::string>* mesh_links, std::string* error);

class FrameColliderInputs {
 public:
  FrameColliderInputs(const FrameInputs& frames, std::string world_frame, std::function<core::Simulation&()> simulation);

  /// Before a frame that ends at `frame_end`: poses every frame collider from tf (at that time, or tf's
  /// newest). A frame tf does not know, or only from long ago, leaves its collider where it was.
  void beforeFrame(const ros::Time& frame_end);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

 private:
  const FrameInputs& frames_;
  std::string world_frame_;
  std::function<core::Simulation&()> simulation_;
  std::vector<std::string> problems_;  ///< per collider: why it was not posed at the last frame ("" if it was)
};

}  // namespace cloth_sim
