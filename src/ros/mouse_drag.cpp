#include "cloth_sim/ros/mouse_drag.h"

#include "cloth_sim/ros/conversions.h"
#include "cloth_sim/ros/ros_time.h"

#include <visualization_msgs/InteractiveMarker.h>
#include <visualization_msgs/InteractiveMarkerControl.h>

namespace cloth_sim {

namespace {

/// The interactive marker's size in rviz, m (its MOVE_3D handle is drawn at this scale).
constexpr float kMarkerScale_m = 0.2f;
/// The handle's opacity: a see-through copy of the mesh over the ~mesh drawing.
constexpr float kHandleAlpha = 0.3f;

Eigen::Vector3d toEigen(const geometry_msgs::Point& p) { return Eigen::Vector3d(p.x, p.y, p.z); }

}  // namespace

MouseDrag::MouseDrag(const std::string& topic_ns, GraspSink grasp, ParticlePicker pick)
    : grasp_(std::move(grasp)), pick_(std::move(pick)) {
  // No spin thread of its own: its feedback runs from ros::spin() like every other callback of the node.
  server_ = std::make_unique<interactive_markers::InteractiveMarkerServer>(topic_ns, "", false);
}

void MouseDrag::update(const core::Simulation& simulation, const std::string& frame_id, const ros::Time& now) {
  if (dragging_) return;
  const double since_s = secondsBetween(last_shape_, now);  // from zero too: a /clock past 2^31 s
  if (!last_shape_.isZero() && since_s >= 0.0 && since_s < kShapeRefreshPeriod_s) return;
  last_shape_ = now;
  visualization_msgs::InteractiveMarker marker;
  marker.header.frame_id = frame_id;
  marker.header.stamp = ros::Time(0);  // follow the latest tf of frame_id
  marker.name = kMarkerName;
  marker.description = "drag the cloth";
  marker.pose.orientation.w = 1.0;  // the mesh's points are in frame_id: the marker sits at its origin
  marker.scale = kMarkerScale_m;
  visualization_msgs::InteractiveMarkerControl control;
  control.name = "drag";
  control.interaction_mode = visualization_msgs::InteractiveMarkerControl::MOVE_3D;
  control.always_visible = true;
  visualization_msgs::Marker mesh = toMeshMarker(simulation, frame_id, ros::Time(0));
  mesh.header = std_msgs::Header();  // inside a control: in the marker's frame
  mesh.color.a = kHandleAlpha;
  for (auto& colour : mesh.colors) colour.a = kHandleAlpha;
  control.markers.push_back(mesh);
  marker.controls.push_back(control);
  server_->insert(marker, [this](const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback) {
    onFeedback(feedback);
  });
  server_->applyChanges();
}

void MouseDrag::endDrag(bool grasp_restored) {
  dragging_ = false;
  restored_grasp_ = grasp_restored;
  last_shape_ = ros::Time();
}

cloth_sim::Grasp MouseDrag::graspMessage(const std_msgs::Header& header, std::uint8_t action) const {
  cloth_sim::Grasp grasp;
  grasp.header = header;
  grasp.id = kMouseGraspId;
  grasp.action = action;
  grasp.particle = particle_;
  return grasp;
}

void MouseDrag::onFeedback(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback) {
  using Feedback = visualization_msgs::InteractiveMarkerFeedback;
  const Eigen::Vector3d marker_m = toEigen(feedback->pose.position);
  if (feedback->event_type == Feedback::MOUSE_DOWN) {
    if (!feedback->mouse_point_valid) return;  // clicked beside the cloth: nothing to pick
    const Eigen::Vector3d clicked_m = toEigen(feedback->mouse_point);
    const int particle = pick_(feedback->header, clicked_m);
    // No particle where tf cannot place the click (the picker says why): no drag begins, so its updates
    // grab nothing either (a grab with particle -1 would take whatever lies nearest a later target).
    if (particle < 0) return;
    if (restored_grasp_ && !dragging_) grasp_(graspMessage(feedback->header, cloth_sim::Grasp::RELEASE));
    restored_grasp_ = false;
    particle_ = particle;
    grab_point_m_ = clicked_m;
    grab_frame_ = feedback->header.frame_id;
    marker_at_grab_m_ = marker_m;
    dragging_ = true;
    cloth_sim::Grasp grab = graspMessage(feedback->header, cloth_sim::Grasp::GRAB);
    grab.target = feedback->mouse_point;
    grasp_(grab);
  } else if (feedback->event_type == Feedback::POSE_UPDATE && dragging_ && feedback->header.frame_id == grab_frame_) {
    // Only in the grab's frame: rviz sends a whole drag in its fixed frame, and a grab the node dropped
    // (a frame tf does not know) must not be made good by updates in another frame.
    cloth_sim::Grasp drag = graspMessage(feedback->header, cloth_sim::Grasp::GRAB);
    const Eigen::Vector3d target_m = grab_point_m_ + (marker_m - marker_at_grab_m_);
    drag.target.x = target_m.x();
    drag.target.y = target_m.y();
    drag.target.z = target_m.z();
    grasp_(drag);
  } else if (feedback->event_type == Feedback::MOUSE_UP && dragging_) {
    dragging_ = false;
    grasp_(graspMessage(feedback->header, cloth_sim::Grasp::RELEASE));
    last_shape_ = ros::Time();  // redraw the marker over the cloth at once, back at the origin
  }
}

}  // namespace cloth_sim
