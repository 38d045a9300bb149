// What a viewer of ClothState can draw: rviz and cloth_viewer's marker hold positions as floats, and
// Ogre's bounding box asserts (rviz aborts) on a coordinate that is finite as a double but infinite as a
// float (above about 3.4e38). One rule for the rviz display and cloth_viewer. Header-only, so that the rviz
// plugin needs none of conversions.cpp's parameter and YAML code.
#pragma once

#include <cloth_sim/ClothState.h>
#include <geometry_msgs/Point.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

namespace cloth_sim {

/// Largest coordinate a viewer draws, m: a thousand times the distance at which the simulation calls a
/// cloth diverged (Simulation::kDivergenceBound_m, 1 km), and far inside a float's range.
inline constexpr double kMaxDrawnCoordinate_m = 1e6;

/// Finite and within kMaxDrawnCoordinate_m of the origin on every axis.
inline bool drawablePosition(const geometry_msgs::Point& p) {
  return std::abs(p.x) <= kMaxDrawnCoordinate_m && std::abs(p.y) <= kMaxDrawnCoordinate_m &&
         std::abs(p.z) <= kMaxDrawnCoordinate_m;  // false for NaN too
}

/// Why a viewer cannot draw `message`, or "" when it can: a side outside [2, max_side], not one position
/// per particle, a position drawablePosition refuses, or active flags that are neither none nor one 0 or 1
/// per particle.
inline std::string undrawableReason(const cloth_sim::ClothState& message, int max_side) {
  // Compared as signed 64-bit: a max_side below 2 must refuse every grid, not wrap to 4 billion.
  const auto side_ok = [max_side](std::uint32_t side) {
    return side >= 2 && static_cast<std::int64_t>(side) <= max_side;
  };
  if (!side_ok(message.rows) || !side_ok(message.cols)) {
    return "rows x cols = " + std::to_string(message.rows) + " x " + std::to_string(message.cols) +
           ": each must be in [2, " + std::to_string(max_side) + "]";
  }
  const std::size_t count = static_cast<std::size_t>(message.rows) * message.cols;
  if (message.positions.size() != count) {
    return std::to_string(message.positions.size()) + " positions for a " + std::to_string(message.rows) + " x " +
           std::to_string(message.cols) + " grid";
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (!drawablePosition(message.positions[i])) {
      std::ostringstream reason;
      reason << "position " << i << " is not finite or beyond " << kMaxDrawnCoordinate_m << " m on an axis";
      return reason.str();
    }
  }
  if (!message.active.empty() && message.active.size() != count) {
    return std::to_string(message.active.size()) + " active flags for " + std::to_string(count) + " particles";
  }
  const auto flag = std::find_if(message.active.begin(), message.active.end(), [](std::uint8_t a) { return a > 1; });
  if (flag != message.active.end()) {
    return "active[" + std::to_string(flag - message.active.begin()) + "] = " + std::to_string(*flag) +
           ": must be 0 or 1";
  }
  return "";
}

}  // namespace cloth_sim
