// The one ROS room where tf frames become poses: a stamped input is expressed in the simulation's frame,
// or dropped with tf's reason (tf-or-drop, written once), and a tf frame becomes a core::Pose. Looked up at
// the latest transform tf has (ros::Time(0)) unless a time is given.
#pragma once

#include "cloth_sim/core/kinematics.h"
#include "cloth_sim/ros/ros_time.h"

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <tf2/exceptions.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>
#include <tf2_ros/buffer.h>

#include <optional>
#include <string>

namespace cloth_sim {

/// How long a tf frame the cloth follows (a gripper's, a robot link collider's) may go without a new
/// transform before it counts as lost: the cloth then holds it where it was last seen, s.
inline constexpr double kFrameLostAfter_s = 0.5;

/// How old a transform stamped `stamp` is at `at`, s, when that is more than kFrameLostAfter_s; nothing
/// when it is fresher, or static (stamp 0: never stale).
inline std::optional<double> staleAge_s(const ros::Time& stamp, const ros::Time& at) {
  const double age_s = secondsBetween(stamp, at);
  if (stamp.isZero() || age_s <= kFrameLostAfter_s) return std::nullopt;
  return age_s;
}

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
    if (inFrame(message.header.frame_id, frame)) {
      *out = message;
      return true;
    }
    geometry_msgs::TransformStamped transform;
    if (!latestTransform(frame, message.header.frame_id, &transform, why)) return false;
    tf2::doTransform(message, *out, transform);
    return true;
  }

  /// Two messages in one header's frame (a grasp's target and force) expressed as express() does, through
  /// one transform: two lookups could take a newer transform for the second than for the first.
  template <typename First, typename Second>
  bool express(const First& first, const Second& second, const std::string& frame, First* first_out,
               Second* second_out, std::string* why) const {
    if (first.header.frame_id != second.header.frame_id) {
      *why = "'" + first.header.frame_id + "' and '" + second.header.frame_id + "' are not one frame";
      return false;
    }
    if (inFrame(first.header.frame_id, frame)) {
      *first_out = first;
      *second_out = second;
      return true;
    }
    geometry_msgs::TransformStamped transform;
    if (!latestTransform(frame, first.header.frame_id, &transform, why)) return false;
    tf2::doTransform(first, *first_out, transform);
    tf2::doTransform(second, *second_out, transform);
    return true;
  }

  /// The pose of `child` in `frame` at `time`, or, when tf has nothing that late yet (a publisher a little
  /// behind the simulation, or one that stopped), the newest it has; *stamp is the stamp of the transform
  /// used. False with *why when tf knows no path between them at all.
  bool poseAtOrNewest(const std::string& child, const std::string& frame, const ros::Time& time, core::Pose* pose,
                      ros::Time* stamp, std::string* why) const;

 private:
  /// A message in `source` is already in `frame` (no frame named: the simulation's own).
  static bool inFrame(const std::string& source, const std::string& frame) { return source.empty() || source == frame; }
  /// tf's latest transform taking `source` coordinates to `frame`'s into *transform; false with tf's *why.
  bool latestTransform(const std::string& frame, const std::string& source, geometry_msgs::TransformStamped* transform,
                       std::string* why) const;

  const tf2_ros::Buffer& buffer_;
};

}  // namespace cloth_sim
