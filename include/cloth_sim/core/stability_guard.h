// The stability guard: decides whether a computed frame is acceptable and, if not, with how many
// substeps to recompute it before giving up and rolling it back.
#pragma once

#include "cloth_sim/core/state.h"

namespace cloth_sim::core {

class StabilityGuard {
 public:
  /// A state further than this from the origin (m) counts as diverged.
  static constexpr double kDivergenceBound_m = 1000.0;
  /// A diverged frame is recomputed with 2x, 4x, ... 2^kDefaultDoublings x the substeps before it is
  /// rolled back.
  static constexpr int kDefaultDoublings = 3;

  explicit StabilityGuard(int doublings = kDefaultDoublings) : doublings_(doublings) {}

  /// Computations of one frame at most: the first, then one per doubling.
  int attempts() const { return doublings_ + 1; }
  /// Substeps of the given attempt (0: the scene's own).
  int substeps(int base_substeps, int attempt) const { return base_substeps << attempt; }
  /// True when the frame's result may be kept: every value finite and within the divergence bound.
  bool accepts(const ClothState& state) const { return isFiniteAndBounded(state, kDivergenceBound_m); }

 private:
  int doublings_;
};

}  // namespace cloth_sim::core
