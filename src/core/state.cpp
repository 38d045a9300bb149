#include "cloth_sim/core/state.h"

namespace cloth_sim::core {

bool isFiniteAndBounded(const ClothState& state, double bound_m) {
  // allFinite() first: a NaN compares false with everything, so the bound alone would not catch it.
  return state.positions_m.allFinite() && state.velocities_m_per_s.allFinite() &&
         state.positions_m.cwiseAbs().maxCoeff() <= bound_m;
}

}  // namespace cloth_sim::core
