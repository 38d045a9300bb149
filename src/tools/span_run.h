// One simulated span of a scene, timed in CPU seconds and checked frame by frame: what every measuring mode of
// cloth_bench (--accuracy, --terms, --solver-sweep, the references) runs.
#pragma once

#include "accuracy.h"

#include "cloth_sim/core/options.h"

#include <string>

namespace cloth_sim::bench {

/// A structural strain beyond this (1000 %) is a cloth that has blown up, even if it is still finite.
constexpr double kDivergedStrain = 10.0;

/// CPU time of this process, s (the measuring modes time with it: other processes on the machine do not count).
double cpuSeconds();

/// Frames in `seconds` of the scene (at least one).
int frameCount(const core::SceneOptions& scene, double seconds);

/// One simulated span of a setting.
struct SpanRun {
  Trajectory trajectory;  ///< positions after every frame (when recorded)
  double cpu_s = 0.0;     ///< CPU time inside advanceFrame
  int frames_run = 0;
  long long substeps_total = 0;
  long long solver_iterations_total = 0;  ///< CG iterations over every accepted substep (implicit Euler)
  int converged_frames = 0;               ///< frames whose every linear solve reached its tolerance
  double max_strain = 0.0;
  int rolled_back = 0;
  int recomputed = 0;
  bool non_finite = false;
  bool diverged = false;
  std::string stopped;  ///< why it ended early
};

/// Runs `frames` frames, stopping at the first that diverges: not finite or beyond the guard's box, rolled back,
/// strained beyond kDivergedStrain, or (fixed_substeps) recomputed with more substeps by the guard.
SpanRun simulateSpan(const core::SceneOptions& scene, int frames, bool record, bool fixed_substeps);

}  // namespace cloth_sim::bench
