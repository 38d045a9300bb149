// The one ROS room where tf frames become poses: a stamped input is expressed in the simulation's frame,
// or dropped with tf's reason (tf-or-drop, written once), and a tf frame becomes a core::Pose. Looked up at
// the latest transform tf has (ros::Time(0)) unless a time is given.
#pragma once

#include "cloth_sim/core/kinematics.h"

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>
#include <tf2_ros/buffer.h>

#include <string>

namespace cloth_sim {

/// A transform message as a core pose (world frame of the simulation: the transform's parent frame).
core::Pose toPose(const geometry_msgs::TransformStamped& transform);

class FrameInputs {
 public:
  /// Keeps a reference: the buffer must outlive this.
  explicit FrameInputs(const tf2_ros::Buffer& buffer) : buffer_(buffer) {}

  /// `message` expressed in `frame` into *out: as it is when its header names no frame or `frame` itself,
  /// else through tf's latest transform (a free vector is only rotated, a point moved too). False with
  /// *why, tf's reason, when tf cannot: the caller drops the message.
  template <typename Stamped>
  bool express(const Stamped& message, const std::string& frame, Stamped* out, std::string* why) const {
    if (message.header.frame_id.empty() || message.header.frame_id == frame) {
      *out = message;
      return true;
    }
    try {
      tf2::doTransform(message, *out, buffer_.lookupTransform(frame, message.header.frame_id, ros::Time(0)));
      return true;
    } catch (const tf2::TransformException& e) {
      *why = e.what();
      return false;
    }
  }

  /// The pose of `child` in `frame` at `time`, or, when tf has nothing that late yet (a publisher a little
  /// behind the simulation, or one that stopped), the newest it has; *stamp is the stamp of the transform
  /// used. False with *why when tf knows no path between them at all.
  bool poseAtOrNewest(const std::string& child, const std::string& frame, const ros::Time& time, core::Pose* pose,
                      ros::Time* stamp, std::string* why) const;

 private:
  const tf2_ros::Buffer& buffer_;
};

}  // namespace cloth_sim
