// Constants shared by the core's kernels.
#pragma once

namespace cloth_sim::core {

constexpr double kTwoPi = 6.283185307179586;  ///< one turn, rad: periodic motions use sin(kTwoPi t / T)

}  // namespace cloth_sim::core
