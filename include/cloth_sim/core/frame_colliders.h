// Colliders on moving frames (issue 14 §4): a robot link's sphere, capsule or box, placed in a tf frame
// by an offset, and posed over each frame by the frame's motion (a PoseTrack, like a gripper). The
// contact kernel that sweeps particles against them is in contact.h (resolveFrameColliders).
//
// Frames: a shape's own frame is its frame's pose composed with the offset (offset then rpy, roll about x,
// pitch about y, yaw about z, applied as R = Rz(yaw) Ry(pitch) Rx(roll), the URDF convention). A capsule
// is every point within radius of the segment of `length` along the shape frame's z axis, centred on its
// origin (so it reaches radius beyond each end); a box has the shape frame's axes and full edge lengths
// `size`.
#pragma once

#include "cloth_sim/core/kinematics.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace cloth_sim::core {

enum class ShapeKind { kSphere, kCapsule, kBox };

/// "sphere", "capsule", "box".
const char* shapeName(ShapeKind shape);
/// False if `name` is none of them.
bool parseShapeName(const std::string& name, ShapeKind* shape);

/// A collider on a tf frame (scene key `frame_colliders`).
struct FrameCollider {
  std::string frame;                  ///< the tf frame it rides on
  ShapeKind shape = ShapeKind::kSphere;
  double radius_m = 0.05;             ///< sphere and capsule
  double length_m = 0.1;              ///< capsule: the core segment's length (the capsule is 2 radius longer)
  Eigen::Vector3d size_m = Eigen::Vector3d::Constant(0.1);  ///< box: full edge lengths along x, y, z
  Eigen::Vector3d offset_m = Eigen::Vector3d::Zero();       ///< the shape's origin in the frame
  Eigen::Vector3d rpy_rad = Eigen::Vector3d::Zero();        ///< the shape's orientation in the frame

  /// Every field equal (a node's URDF colliders against those a state file holds).
  bool operator==(const FrameCollider& other) const {
    return frame == other.frame && shape == other.shape && radius_m == other.radius_m &&
           length_m == other.length_m && size_m == other.size_m && offset_m == other.offset_m &&
           rpy_rad == other.rpy_rad;
  }
  /// The shape's frame in the collider's tf frame.
  Pose offsetPose() const;
  /// The radius of a sphere about the shape's origin that holds the whole shape, m.
  double boundingRadius_m() const;
  /// The thinnest the shape is (twice the radius, or the smallest edge), m: the sweep's sampling scale.
  double thickness_m() const;
};

/// Signed distance from a point in the shape's own frame to its surface (positive outside), m, and the
/// outward unit normal there (shape frame).
double shapeSignedDistance(const FrameCollider& collider, const Eigen::Vector3d& local_m, Eigen::Vector3d* normal);

/// Where a frame collider's shape is over the current frame (an input, like a gripper's track): unseen
/// until its frame's pose first arrives (it then collides with nothing).
struct FrameColliderTrack {
  bool seen = false;
  PoseTrack track;  ///< the SHAPE's pose (frame pose times offset), world frame
};

}  // namespace cloth_sim::core
