#include "solver_sweep.h"

#include "cloth_sim/core/constants.h"

#include <algorithm>
#include <cmath>

namespace cloth_sim::bench {

namespace {

using core::kMillisecondsPerSecond;

}  // namespace

const std::vector<double>& defaultSweepTolerances() {
  static const std::vector<double> tolerances = {1e-1, 3e-2, 1e-2, 1e-3, 1e-4, 1e-6};
  return tolerances;
}

const std::vector<int>& defaultSweepCaps() {
  static const std::vector<int> caps = {10, 25, 50, 100, 200, kUncappedSolverIterations};
  return caps;
}

std::string capText(int max_iterations) {
  return max_iterations >= kUncappedSolverIterations ? std::string("none") : std::to_string(max_iterations);
}

core::SceneOptions withSolverSetting(const core::SceneOptions& scene, const SolverSetting& setting) {
  core::SceneOptions options = scene;
  options.integrator = core::IntegratorKind::kImplicitEuler;
  options.solver.tolerance = setting.tolerance;
  options.solver.max_iterations = setting.max_iterations;
  return options;
}

double referenceCheckTolerance(double reference_tolerance) {
  return std::max(reference_tolerance * kReferenceCheckFactor, core::OptionLimits::kMinSolverTolerance);
}

SpanRun solverReference(const core::SceneOptions& scene, int frames, double tolerance) {
  return simulateSpan(withSolverSetting(scene, SolverSetting{tolerance, kUncappedSolverIterations}), frames, true,
                      false);
}

SolverMeasurement measureSolverSetting(const core::SceneOptions& scene, const SolverSetting& setting, int frames,
                                       const Trajectory& reference, double min_timing_s, int max_timing_runs) {
  const core::SceneOptions options = withSolverSetting(scene, setting);
  SolverMeasurement m;
  m.setting = setting;
  m.run = simulateSpan(options, frames, true, false);
  m.error = compareTrajectories(m.run.trajectory, reference);
  const std::size_t compared = std::min(m.run.trajectory.size(), reference.size());
  if (compared > 0) {
    const Eigen::Matrix3Xd& x = m.run.trajectory[compared - 1];
    const Eigen::Matrix3Xd& x_ref = reference[compared - 1];
    m.final_max_error_m = x.cols() > 0 ? (x - x_ref).colwise().norm().maxCoeff() : 0.0;
  }
  m.run.trajectory.clear();
  m.stable = !m.run.diverged && m.run.frames_run == frames;
  const int frames_run = std::max(1, m.run.frames_run);
  const long long steps = std::max(1LL, m.run.substeps_total);
  m.iterations_per_step = static_cast<double>(m.run.solver_iterations_total) / static_cast<double>(steps);
  m.converged_share = static_cast<double>(m.run.converged_frames) / frames_run;
  m.mean_substeps = static_cast<double>(m.run.substeps_total) / frames_run;
  double best_cpu_s = m.run.cpu_s, total_cpu_s = m.run.cpu_s;
  for (int runs = 1; m.stable && runs < max_timing_runs && total_cpu_s < min_timing_s; ++runs) {
    const double cpu_s = simulateSpan(options, frames, false, false).cpu_s;
    best_cpu_s = std::min(best_cpu_s, cpu_s);
    total_cpu_s += cpu_s;
  }
  m.ms_per_frame = best_cpu_s * kMillisecondsPerSecond / frames_run;
  return m;
}

}  // namespace cloth_sim::bench
