// The solver knob of implicit Euler, measured: `cloth_bench --solver-sweep` runs a scene with each CG tolerance and
// iteration cap and compares it with the same scene solved to 1e-9 without a cap (the converged reference), so
// that advice such as "cap CG at 10 for speed" comes with the error it costs.
#pragma once

#include "accuracy.h"
#include "span_run.h"

#include "cloth_sim/core/options.h"

#include <string>
#include <vector>

namespace cloth_sim::bench {

/// The reference solves to this relative residual: far below any setting swept, above rounding.
constexpr double kReferenceSolverTolerance = 1e-9;
/// "No cap": the largest cap the scene parser accepts (solver_max_iterations).
constexpr int kUncappedSolverIterations = core::OptionLimits::kMaxSolverIterations;

/// One setting of implicit Euler's solve (the scene keys solver_tolerance and solver_max_iterations).
struct SolverSetting {
  double tolerance = 1e-3;
  int max_iterations = kUncappedSolverIterations;
};

/// Tolerances swept without a cap, and caps swept at the scene's tolerance (kUncappedSolverIterations last).
const std::vector<double>& defaultSweepTolerances();
const std::vector<int>& defaultSweepCaps();

/// "none" for kUncappedSolverIterations, else the number.
std::string capText(int max_iterations);

/// The scene with implicit Euler and the setting's tolerance and cap; everything else (substeps, the guard, any
/// other solver key such as the preconditioner) as given.
core::SceneOptions withSolverSetting(const core::SceneOptions& scene, const SolverSetting& setting);

/// What one setting costs and how far its cloth is from the reference's.
struct SolverMeasurement {
  SolverSetting setting;
  double ms_per_frame = 0.0;         ///< CPU per frame, the cheapest of the timing runs
  double iterations_per_step = 0.0;  ///< mean CG iterations per integrator step
  double converged_share = 0.0;      ///< frames whose every solve reached the tolerance, over frames run (0..1)
  double mean_substeps = 0.0;        ///< integrator steps per frame (more than the scene's where the guard recomputed)
  TrajectoryError error;             ///< against the reference over every frame and particle
  double final_max_error_m = 0.0;    ///< largest |x - x_ref| at the last frame compared
  SpanRun run;                       ///< the recorded run (trajectory dropped), with its strain and guard counts
  bool stable = false;               ///< ran every frame without diverging
};

/// The reference is checked against a solve this much tighter: where the two differ (a cloth that buckles or flutters
/// turns rounding-level differences into millimetres), errors that small are the scene's sensitivity, not the solve's.
constexpr double kReferenceCheckFactor = 1e-3;

/// reference_tolerance x kReferenceCheckFactor, but not below the smallest tolerance the scene parser accepts.
double referenceCheckTolerance(double reference_tolerance);

/// The reference run: the scene with implicit Euler solved to `tolerance` without a cap, every frame recorded.
SpanRun solverReference(const core::SceneOptions& scene, int frames, double tolerance = kReferenceSolverTolerance);

/// Runs the scene at `setting` for `frames` frames (timed again, the cheapest run kept, until the runs add up to
/// min_timing_s of CPU, at most max_timing_runs times) and compares every frame with `reference`.
SolverMeasurement measureSolverSetting(const core::SceneOptions& scene, const SolverSetting& setting, int frames,
                                       const Trajectory& reference, double min_timing_s, int max_timing_runs);

}  // namespace cloth_sim::bench
