// The paper's mouse (§5) in rviz: an interactive marker shaped like the cloth. Mouse-down on it grabs the
// particle nearest to the clicked point, dragging moves the grasp's target by as much as the mouse moved
// the marker, mouse-up lets go. Each event becomes a cloth_sim/Grasp for the node's ~grasp handling (the
// one grasp mechanism; the drag uses grasp id kMouseGraspId).
#pragma once

#include "cloth_sim/Grasp.h"
#include "cloth_sim/core/simulation.h"

#include <interactive_markers/interactive_marker_server.h>
#include <ros/ros.h>
#include <visualization_msgs/InteractiveMarkerFeedback.h>

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>

namespace cloth_sim {

class MouseDrag {
 public:
  /// The grasp id the mouse holds with (a ~grasp user picking the same id moves the mouse's grasp).
  static constexpr std::uint32_t kMouseGraspId = 0xFFFFFFFFu;
  /// The interactive marker's name on the server.
  static constexpr const char* kMarkerName = "cloth";
  /// The marker's cloth shape is refreshed at most this often while nobody drags, s (the server resends
  /// the whole mesh each time).
  static constexpr double kShapeRefreshPeriod_s = 0.5;

  using GraspSink = std::function<void(const cloth_sim::Grasp&)>;
  /// The particle nearest to a point given in `header.frame_id` (the frame the feedback came in: rviz's
  /// fixed frame, not necessarily the node's frame_id), as the cloth stands now; -1 where tf cannot
  /// express the point in the node's frame (the picker warns with tf's reason, and no drag begins).
  using ParticlePicker = std::function<int(const std_msgs::Header&, const Eigen::Vector3d&)>;

  /// Serves the marker under topic namespace `topic_ns` (its feedback topic is topic_ns + "/feedback");
  /// `grasp` receives the grab, drag and release messages; `pick` names the clicked particle.
  MouseDrag(const std::string& topic_ns, GraspSink grasp, ParticlePicker pick);

  /// Redraws the marker as the cloth stands (at most every kShapeRefreshPeriod_s, never while dragging).
  void update(const core::Simulation& simulation, const std::string& frame_id, const ros::Time& now);
  /// A reset or a load let the drag's grasp go: the rest of the drag (its pose updates and mouse-up) grabs
  /// and releases nothing, until the next mouse-down; the marker is redrawn over the cloth as it stands.
  /// `grasp_restored`: the simulation holds a grasp with the mouse's id all the same (a state file saved
  /// mid-drag), which the next mouse-down releases before it grabs: a GRAB of an id already held moves
  /// that grasp's target and keeps its particle, so the click dragged the file's particle, not its own.
  void endDrag(bool grasp_restored = false);

 private:
  void onFeedback(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback);
  cloth_sim::Grasp graspMessage(const std_msgs::Header& header, std::uint8_t action) const;

  GraspSink grasp_;
  ParticlePicker pick_;
  /// The particle picked on mouse-down: every GRAB of the drag names it, so a queue that keeps only the
  /// last command of an id (GraspCommandQueue) still holds the clicked particle.
  int particle_ = -1;
  std::unique_ptr<interactive_markers::InteractiveMarkerServer> server_;
  bool dragging_ = false;
  bool restored_grasp_ = false;  ///< the simulation holds a mouse grasp no drag of ours made (endDrag)
  /// Where the mouse went down (in the marker's frame) and where the marker stood then.
  Eigen::Vector3d grab_point_m_ = Eigen::Vector3d::Zero();
  std::string grab_frame_;  ///< the frame of the mouse-down that began the drag
  Eigen::Vector3d marker_at_grab_m_ = Eigen::Vector3d::Zero();
  ros::Time last_shape_;
};

}  // namespace cloth_sim
