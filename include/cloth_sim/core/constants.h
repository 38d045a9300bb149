// Constants shared by the core's kernels (and the node and tools above it).
#pragma once

#include <cmath>

namespace cloth_sim::core {

constexpr double kPi = 3.14159265358979323846;  ///< half a turn, rad
constexpr double kTwoPi = 2.0 * kPi;  ///< one turn, rad: periodic motions use sin(kTwoPi t / T)
constexpr double kMillisecondsPerSecond = 1000.0;  ///< costs are timed in seconds and reported in ms

/// sin(2 pi t / T): the one periodic motion that pins, spheres and gusts share (times an amplitude).
inline double periodicSine(double time_s, double period_s) { return std::sin(kTwoPi * time_s / period_s); }
/// Its rate of change, 1/s: (2 pi / T) cos(2 pi t / T).
inline double periodicSineRate(double time_s, double period_s) {
  const double angular_rate = kTwoPi / period_s;
  return angular_rate * std::cos(angular_rate * time_s);
}

}  // namespace cloth_sim::core
