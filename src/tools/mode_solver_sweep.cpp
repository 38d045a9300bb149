// cloth_bench --solver-sweep: implicit Euler's CG tolerance (uncapped) and iteration cap (at the scene's tolerance),
// each against the same scene solved to 1e-9 without a cap: cost per frame, CG iterations per step, the share of
// frames whose solves converged, position error and strain. The measuring is in solver_sweep.cpp.
#include "accuracy_modes.h"
#include "solver_sweep.h"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace cloth_sim::bench {

namespace {

constexpr double kPercent = 100.0;

/// One row of the sweep: which sweep it belongs to, and the setting.
struct SweepRow {
  std::string sweep;  ///< "reference", "tolerance" (no cap) or "cap" (at the scene's tolerance)
  SolverSetting setting;
};

bool sameSetting(const SolverSetting& a, const SolverSetting& b) {
  return a.tolerance == b.tolerance && a.max_iterations == b.max_iterations;
}

/// The reference first, then the tolerances without a cap, then the caps at the scene's tolerance; a setting
/// already listed is not run again.
std::vector<SweepRow> sweepRows(const ToolOptions& options, const core::SceneOptions& scene,
                                double reference_tolerance) {
  std::vector<SweepRow> rows = {{"reference", {reference_tolerance, kUncappedSolverIterations}}};
  const auto add = [&](const std::string& sweep, const SolverSetting& setting) {
    for (const SweepRow& row : rows) {
      if (sameSetting(row.setting, setting)) return;
    }
    rows.push_back({sweep, setting});
  };
  const std::vector<double>& tolerances =
      options.solver_tolerances.empty() ? defaultSweepTolerances() : options.solver_tolerances;
  const std::vector<int>& caps = options.solver_caps.empty() ? defaultSweepCaps() : options.solver_caps;
  for (double tolerance : tolerances) add("tolerance", {tolerance, kUncappedSolverIterations});
  for (int cap : caps) add("cap", {scene.solver.tolerance, cap});
  return rows;
}

void printTable(std::ostream& out, const std::vector<SweepRow>& rows, const std::vector<SolverMeasurement>& results) {
  out << std::left << std::setw(11) << "sweep" << std::right << std::setw(10) << "tolerance" << std::setw(6) << "cap"
      << std::setw(10) << "ms/frame" << std::setw(11) << "CG it/step" << std::setw(11) << "converged"
      << std::setw(11) << "max err m" << std::setw(13) << "final err m" << std::setw(12) << "max strain"
      << std::setw(12) << "steps/frame" << "  stability\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SolverMeasurement& m = results[i];
    out << std::left << std::setw(11) << rows[i].sweep << std::right << std::setw(10)
        << formatNumber(m.setting.tolerance) << std::setw(6) << capText(m.setting.max_iterations) << std::setw(10)
        << formatNumber(m.ms_per_frame) << std::setw(11) << formatNumber(m.iterations_per_step) << std::setw(11)
        << formatNumber(kPercent * m.converged_share) + " %" << std::setw(11) << formatNumber(m.error.max_m)
        << std::setw(13) << formatNumber(m.final_max_error_m) << std::setw(12)
        << formatNumber(kPercent * m.run.max_strain) + " %" << std::setw(12) << formatNumber(m.mean_substeps)
        << "  " << stabilityText(m.stable, m.run) << "\n";
  }
}

std::string csvText(const std::vector<std::pair<std::string, std::string>>& metadata, const std::vector<SweepRow>& rows,
                    const std::vector<SolverMeasurement>& results) {
  std::ostringstream out;
  out << std::setprecision(6);
  for (const auto& [key, value] : metadata) out << "# " << key << ": " << value << "\n";
  out << "sweep,tolerance,max_iterations,capped,ms_per_frame,cg_iterations_per_step,converged_share,max_error_m,"
         "rms_error_m,final_max_error_m,max_strain,mean_substeps,recomputed,rolled_back,stable,frames_run,stopped\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const SolverMeasurement& m = results[i];
    out << rows[i].sweep << "," << m.setting.tolerance << "," << m.setting.max_iterations << ","
        << (m.setting.max_iterations < kUncappedSolverIterations ? 1 : 0) << "," << m.ms_per_frame << ","
        << m.iterations_per_step << "," << m.converged_share << "," << m.error.max_m << "," << m.error.rms_m << ","
        << m.final_max_error_m << "," << m.run.max_strain << "," << m.mean_substeps << "," << m.run.recomputed << ","
        << m.run.rolled_back << "," << (m.stable ? 1 : 0) << "," << m.run.frames_run << "," << csvField(m.run.stopped)
        << "\n";
  }
  return out.str();
}

/// The cheapest stable setting (the reference itself left out) whose max error is within options.max_error_m, or
/// within the reference's own uncertainty where that is larger, as lines to paste.
std::string recommendation(const ToolOptions& options, const std::vector<SweepRow>& rows,
                           const std::vector<SolverMeasurement>& results, double reference_uncertainty_m) {
  std::vector<CostError> points;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const SolverMeasurement& m = results[i];
    points.push_back({m.ms_per_frame, m.error.max_m, m.stable && rows[i].sweep != "reference"});
  }
  const double max_error_m = std::max(options.max_error_m, reference_uncertainty_m);
  const std::string bound = "max error <= " + formatNumber(max_error_m) + " m" +
                            (max_error_m > options.max_error_m ? " (the reference's own uncertainty)" : "");
  std::ostringstream out;
  const std::optional<std::size_t> best = cheapestWithin(points, max_error_m);
  if (!best) {
    out << "recommendation: no setting tried meets " << bound << "\n";
    return out.str();
  }
  const SolverMeasurement& m = results[*best];
  out << "recommendation (cheapest with " << bound << "): solver_tolerance " << formatNumber(m.setting.tolerance)
      << ", solver_max_iterations " << m.setting.max_iterations << ": " << formatNumber(m.ms_per_frame)
      << " ms CPU per frame, max error " << formatNumber(m.error.max_m) << " m, max strain "
      << formatNumber(kPercent * m.run.max_strain) << " %\n"
      << "  scene file:   solver_tolerance: " << formatNumber(m.setting.tolerance) << "\n"
      << "                solver_max_iterations: " << m.setting.max_iterations << "\n"
      << "  cloth_bench:  --set solver_tolerance=" << formatNumber(m.setting.tolerance)
      << " --set solver_max_iterations=" << m.setting.max_iterations << "\n";
  return out.str();
}

}  // namespace

int runSolverSweep(const ToolOptions& options, const core::SceneOptions& given) {
  core::SceneOptions scene = given;
  scene.integrator = core::IntegratorKind::kImplicitEuler;
  const int frames = frameCount(scene, options.seconds);
  const double span_s = frames * scene.frameDuration_s();
  const double reference_tolerance = options.reference_solver_tolerance.value_or(kReferenceSolverTolerance);
  std::string keys;
  for (const SceneOverride& entry : options.overrides) keys += " " + entry.key + "=" + entry.value;
  std::cout << "solver sweep: scene " << scene.name << (options.dynamic ? " released flat" : "") << " "
            << gridText(scene.rows, scene.cols) << ", implicit_euler x " << substepsText(scene) << ", "
            << formatNumber(span_s) << " s (" << frames << " frames); --set:" << (keys.empty() ? " none" : keys)
            << "\n";

  const std::vector<SweepRow> rows = sweepRows(options, scene, reference_tolerance);
  Progress progress("solver sweep");
  progress.show(0, "reference");
  const SpanRun reference = solverReference(scene, frames, reference_tolerance);
  if (reference.diverged || reference.frames_run != frames) {
    std::cerr << "cloth_bench: the reference (CG to " << formatNumber(reference_tolerance)
              << " without a cap) did not run every frame: " << reference.stopped << "\n";
    return kExitRunFailed;
  }
  // The reference against a tighter solve: how far apart two solves that both converged end up on this scene.
  const double check_tolerance = referenceCheckTolerance(reference_tolerance);
  progress.show(0, "reference check, tolerance " + formatNumber(check_tolerance));
  const SpanRun check = solverReference(scene, frames, check_tolerance);
  const TrajectoryError uncertainty = compareTrajectories(check.trajectory, reference.trajectory);
  std::vector<SolverMeasurement> results;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    progress.show(static_cast<long long>(100 * i / rows.size()),
                  "tolerance " + formatNumber(rows[i].setting.tolerance) + ", cap " +
                      capText(rows[i].setting.max_iterations));
    results.push_back(measureSolverSetting(scene, rows[i].setting, frames, reference.trajectory, options.min_timing_s,
                                           kMaxTimingRuns));
  }
  progress.show(100, "done");

  std::cout << "reference: CG to a relative residual of " << formatNumber(reference_tolerance)
            << " without a cap; tolerance rows: no cap; cap rows: the scene's tolerance "
            << formatNumber(scene.solver.tolerance) << "\n"
            << "cost: CPU per frame (" << timingRunsText(options.min_timing_s)
            << "); converged: frames whose every solve reached its tolerance; error: |x - x_ref| of any "
               "particle, the largest over every frame (max) and at the last frame (final)\n";
  std::cout << "reference check: CG to " << formatNumber(check_tolerance) << " differs from the reference by "
            << formatNumber(uncertainty.max_m) << " m at most over every frame ("
            << formatNumber(check.max_strain * kPercent) << " % max strain" << (check.diverged ? ", DIVERGED " + check.stopped : "")
            << "): errors that small are this scene's sensitivity to the last digits, not the solve's\n";
  printTable(std::cout, rows, results);
  std::cout << "\n" << recommendation(options, rows, results, uncertainty.max_m);

  const std::vector<std::pair<std::string, std::string>> metadata = {
      {"scene", scene.name},
      {"released_flat", options.dynamic ? "1" : "0"},
      {"grid", gridText(scene.rows, scene.cols)},
      {"substeps", substepsText(scene)},
      {"seconds", formatNumber(span_s, 6)},
      {"frames", std::to_string(frames)},
      {"set", keys.empty() ? "none" : keys.substr(1)},
      {"reference_tolerance", formatNumber(reference_tolerance)},
      {"reference_check_tolerance", formatNumber(check_tolerance)},
      {"reference_check_max_error_m", formatNumber(uncertainty.max_m)},
      {"scene_tolerance", formatNumber(scene.solver.tolerance)}};
  return writeCsvText(options, csvText(metadata, rows, results)) ? kExitOk : kExitRunFailed;
}

}  // namespace cloth_sim::bench
