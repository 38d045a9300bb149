#include "cloth_sim/ros/frame_inputs.h"

namespace cloth_sim {

core::Pose toPose(const geometry_msgs::TransformStamped& transform) {
  const geometry_msgs::Vector3& t = transform.transform.translation;
  const geometry_msgs::Quaternion& q = transform.transform.rotation;
  core::Pose pose;
  pose.position_m = Eigen::Vector3d(t.x, t.y, t.z);
  pose.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized();
  return pose;
}

bool FrameInputs::latestTransform(const std::string& frame, const std::string& source,
                                  geometry_msgs::TransformStamped* transform, std::string* why) const {
  try {
    *transform = buffer_.lookupTransform(frame, source, ros::Time(0));
    return true;
  } catch (const tf2::TransformException& e) {
    *why = e.what();
    return false;
  }
}

bool FrameInputs::poseAtOrNewest(const std::string& child, const std::string& frame, const ros::Time& time,
                                 core::Pose* pose, ros::Time* stamp, std::string* why) const {
  try {
    const geometry_msgs::TransformStamped transform =
        buffer_.canTransform(frame, child, time) ? buffer_.lookupTransform(frame, child, time)
                                                 : buffer_.lookupTransform(frame, child, ros::Time(0));
    *pose = toPose(transform);
    *stamp = transform.header.stamp;
    return true;
  } catch (const tf2::TransformException& e) {
    *why = e.what();
    return false;
  }
}

}  // namespace cloth_sim
