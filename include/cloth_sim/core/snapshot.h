// A complete snapshot of a running simulation: what Simulation::snapshot() returns and
// Simulation::restore() accepts, and what the state file (io/state_file.h) stores.
#pragma once

#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/stability_guard.h"
#include "cloth_sim/core/state.h"

namespace cloth_sim::core {

/// Options (with their live tuning) + integrated state + inputs (grasps, pin hooks, wind) + what `auto`
/// remembers: restoring exactly these and advancing gives the same bits as never having stopped.
struct SimulationSnapshot {
  SceneOptions options;
  ClothState state;
  ClothInputs inputs;
  GuardMemory guard;
  /// Substeps the state's frame was computed with (Simulation::lastFrameSubsteps): not needed to
  /// continue, but what a restored run reports for its first frame, as the run that saved it did. 0: not
  /// known (a state file older than version 6); restoring then reports what the next frame starts from.
  int last_frame_substeps = 0;
};

}  // namespace cloth_sim::core
