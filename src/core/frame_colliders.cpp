#include "cloth_sim/core/frame_colliders.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace cloth_sim::core {

namespace {

/// Below this a direction is undefined, m: a point on a capsule's axis or a sphere's centre is pushed out
/// along the shape frame's +x.
constexpr double kTinyLength_m = 1e-12;

}  // namespace

const char* shapeName(ShapeKind shape) {
  switch (shape) {
    case ShapeKind::kSphere: return "sphere";
    case ShapeKind::kCapsule: return "capsule";
    case ShapeKind::kBox: return "box";
  }
  return "sphere";
}

bool parseShapeName(const std::string& name, ShapeKind* shape) {
  for (const ShapeKind kind : {ShapeKind::kSphere, ShapeKind::kCapsule, ShapeKind::kBox}) {
    if (name == shapeName(kind)) {
      *shape = kind;
      return true;
    }
  }
  return false;
}

Pose FrameCollider::offsetPose() const {
  Pose pose;
  pose.position_m = offset_m;
  pose.orientation = Eigen::AngleAxisd(rpy_rad.z(), Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(rpy_rad.y(), Eigen::Vector3d::UnitY()) *
                     Eigen::AngleAxisd(rpy_rad.x(), Eigen::Vector3d::UnitX());
  return pose;
}

double FrameCollider::boundingRadius_m() const {
  switch (shape) {
    case ShapeKind::kSphere: return radius_m;
    case ShapeKind::kCapsule: return radius_m + 0.5 * length_m;
    case ShapeKind::kBox: return 0.5 * size_m.norm();
  }
  return radius_m;
}

double FrameCollider::thickness_m() const {
  return shape == ShapeKind::kBox ? size_m.minCoeff() : 2.0 * radius_m;
}

double shapeSignedDistance(const FrameCollider& collider, const Eigen::Vector3d& local_m, Eigen::Vector3d* normal) {
  switch (collider.shape) {
    case ShapeKind::kSphere:
    case ShapeKind::kCapsule: {
      // Distance to the core: the centre, or the segment along z of the capsule's length.
      const double half_m = collider.shape == ShapeKind::kCapsule ? 0.5 * collider.length_m : 0.0;
      const Eigen::Vector3d core(0.0, 0.0, std::clamp(local_m.z(), -half_m, half_m));
      const Eigen::Vector3d away = local_m - core;
      const double length = away.norm();
      *normal = length > kTinyLength_m ? Eigen::Vector3d(away / length) : Eigen::Vector3d::UnitX();
      return length - collider.radius_m;
    }
    case ShapeKind::kBox: {
      const Eigen::Vector3d half = 0.5 * collider.size_m;
      const Eigen::Vector3d beyond = local_m.cwiseAbs() - half;  // > 0 along an axis where it is outside
      const Eigen::Vector3d outside = beyond.cwiseMax(0.0);
      if (outside.norm() > kTinyLength_m) {
        const Eigen::Vector3d clamped = local_m.cwiseMax(-half).cwiseMin(half);
        *normal = (local_m - clamped).normalized();
        return outside.norm();
      }
      // Inside: out through the nearest face.
      Eigen::Index axis = 0;
      const double nearest = beyond.maxCoeff(&axis);
      *normal = (local_m[axis] >= 0.0 ? 1.0 : -1.0) * Eigen::Vector3d::Unit(axis);
      return nearest;
    }
  }
  *normal = Eigen::Vector3d::UnitZ();
  return 0.0;
}

}  // namespace cloth_sim::core
