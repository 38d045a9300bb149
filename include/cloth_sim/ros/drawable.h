// What a viewer of ClothState can draw: rviz and cloth_viewer's marker hold positions as floats, and
// Ogre's bounding box asserts (rviz aborts) on a coordinate that is finite as a double but infinite as a
// float (above about 3.4e38). One rule for the rviz display and cloth_viewer.
#pragma once

#include <geometry_msgs/Point.h>

#include <cmath>

namespace cloth_sim {

/// Largest coordinate a viewer draws, m: a thousand times the distance at which the simulation calls a
/// cloth diverged (Simulation::kDivergenceBound_m, 1 km), and far inside a float's range.
inline constexpr double kMaxDrawnCoordinate_m = 1e6;

/// Finite and within kMaxDrawnCoordinate_m of the origin on every axis.
inline bool drawablePosition(const geometry_msgs::Point& p) {
  return std::abs(p.x) <= kMaxDrawnCoordinate_m && std::abs(p.y) <= kMaxDrawnCoordinate_m &&
         std::abs(p.z) <= kMaxDrawnCoordinate_m;  // false for NaN too
}

}  // namespace cloth_sim
