// cloth_bench --accuracy: cost against error of every integrator and substep count on a scene, against a converged
// rk4 reference, with the Pareto front and a setting to paste.
#include "accuracy_modes.h"

#include "cloth_sim/core/options.h"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>
#include <utility>

namespace cloth_sim::bench {

namespace {

/// One simulated second per CPU second: real time.
constexpr double kRealTimeCost_ms_per_s = 1e3;
/// Weights for the progress percentage: force evaluations per step, implicit Euler's CG iterations counted in.
constexpr int kProgressEvaluations[] = {1, 1, 2, 4, 8};
/// Substeps `auto` is assumed to take, for the progress percentage only.
constexpr int kProgressAutoSubsteps = 16;

struct SettingResult {
  core::IntegratorKind integrator = core::IntegratorKind::kRK4;
  std::string substeps_label;  ///< "8" or "auto"
  double mean_substeps = 0.0;
  double cost_ms_per_s = 0.0;
  TrajectoryError error;
  SpanRun run;  ///< trajectory dropped after comparison
  bool stable = false;
  bool pareto = false;
};

struct Setting {
  core::IntegratorKind integrator;
  std::string substeps_label;
  core::SceneOptions scene;
  bool fixed;
  int progress_weight;
};

/// Every integrator x substep count (the guard's recomputations off: a fixed count stays fixed), and `auto` (the
/// guard as shipped).
std::vector<Setting> sweepSettings(const ToolOptions& options, const core::SceneOptions& scene) {
  std::vector<Setting> settings;
  for (core::IntegratorKind kind : options.integrators) {
    const int evaluations = kProgressEvaluations[static_cast<int>(kind)];
    for (int substeps : options.substep_counts) {
      core::SceneOptions s = scene;
      s.integrator = kind;
      s.substeps = substeps;
      s.guard_retries = false;
      settings.push_back({kind, std::to_string(substeps), s, true, substeps * evaluations});
    }
    core::SceneOptions s = scene;
    s.integrator = kind;
    s.substeps = core::SceneOptions::kAutoSubsteps;
    settings.push_back({kind, core::kAutoSubstepsName, s, false, kProgressAutoSubsteps * evaluations});
  }
  return settings;
}

SettingResult runSetting(const Setting& setting, int frames, const Trajectory& reference, double min_timing_s) {
  SettingResult result;
  result.integrator = setting.integrator;
  result.substeps_label = setting.substeps_label;
  result.run = simulateSpan(setting.scene, frames, true, setting.fixed);
  result.error = compareTrajectories(result.run.trajectory, reference);
  result.run.trajectory.clear();
  result.stable = !result.run.diverged && result.run.frames_run == frames;
  result.mean_substeps = static_cast<double>(result.run.substeps_total) / std::max(1, result.run.frames_run);
  double best_cpu_s = result.run.cpu_s, total_cpu_s = result.run.cpu_s;
  for (int runs = 1; result.stable && runs < kMaxTimingRuns && total_cpu_s < min_timing_s; ++runs) {
    const double cpu_s = simulateSpan(setting.scene, frames, false, setting.fixed).cpu_s;
    best_cpu_s = std::min(best_cpu_s, cpu_s);
    total_cpu_s += cpu_s;
  }
  const double simulated_s = result.run.frames_run * setting.scene.frameDuration_s();
  result.cost_ms_per_s = best_cpu_s * kMillisecondsPerSecond / simulated_s;
  return result;
}

std::vector<CostError> costErrors(const std::vector<SettingResult>& results) {
  std::vector<CostError> points;
  for (const SettingResult& r : results) points.push_back({r.cost_ms_per_s, r.error.max_m, r.stable});
  return points;
}

std::string pasteable(const SettingResult& r) {
  const char* name = core::integratorName(r.integrator);
  std::ostringstream out;
  out << "  scene file:   integrator: " << name << "\n"
      << "                substeps: " << r.substeps_label << "\n"
      << "  node:         _integrator:=" << name << " _substeps:=" << r.substeps_label << "\n"
      << "  cloth_bench:  --set integrator=" << name << " --set substeps=" << r.substeps_label << "\n";
  return out.str();
}

std::string describeSetting(const SettingResult& r) {
  std::ostringstream out;
  out << core::integratorName(r.integrator) << " at " << r.substeps_label << " substeps: "
      << formatNumber(r.cost_ms_per_s) << " ms CPU per simulated second ("
      << formatNumber(kRealTimeCost_ms_per_s / r.cost_ms_per_s) << "x real time), max error "
      << formatNumber(r.error.max_m) << " m, RMS " << formatNumber(r.error.rms_m) << " m";
  return out.str();
}

/// The recommendation for the chosen budget, as text a user can paste.
std::string recommendation(const ToolOptions& options, const std::vector<SettingResult>& results) {
  const std::vector<CostError> points = costErrors(results);
  std::ostringstream out;
  if (options.realtime) {
    const std::optional<std::size_t> best = mostAccurateWithin(points, kRealTimeCost_ms_per_s);
    if (!best) {
      out << "recommendation (at least real time on this machine): none of the settings runs at real time; "
             "use a coarser grid\n";
      return out.str();
    }
    out << "recommendation (most accurate at least at real time on this machine): "
        << describeSetting(results[*best]) << "\n"
        << pasteable(results[*best]);
    return out.str();
  }
  const std::optional<std::size_t> best = cheapestWithin(points, options.max_error_m);
  if (best) {
    out << "recommendation (cheapest with max error <= " << formatNumber(options.max_error_m)
        << " m): " << describeSetting(results[*best]) << "\n"
        << pasteable(results[*best]);
    return out.str();
  }
  const std::optional<std::size_t> closest = mostAccurateWithin(points, std::numeric_limits<double>::infinity());
  out << "recommendation: no setting tried meets max error <= " << formatNumber(options.max_error_m) << " m";
  if (closest) out << "; the most accurate is " << describeSetting(results[*closest]) << "\n" << pasteable(results[*closest]);
  else out << " and none was stable\n";
  return out.str();
}

void printTable(std::ostream& out, const std::vector<SettingResult>& results) {
  out << std::left << std::setw(17) << "integrator" << std::right << std::setw(9) << "substeps" << std::setw(12)
      << "ms CPU/s" << std::setw(10) << "x real" << std::setw(11) << "RMS err m" << std::setw(11) << "max err m"
      << std::setw(11) << "max strain" << "  pareto  stability\n";
  for (const SettingResult& r : results) {
    std::string substeps = r.substeps_label;
    if (r.substeps_label == core::kAutoSubstepsName) substeps += "(" + formatNumber(r.mean_substeps, 2) + ")";
    out << std::left << std::setw(17) << core::integratorName(r.integrator) << std::right << std::setw(9) << substeps
        << std::setw(12) << formatNumber(r.cost_ms_per_s) << std::setw(10)
        << formatNumber(kRealTimeCost_ms_per_s / r.cost_ms_per_s) << std::setw(11)
        << (r.stable ? formatNumber(r.error.rms_m) : "-") << std::setw(11)
        << (r.stable ? formatNumber(r.error.max_m) : "-") << std::setw(11) << formatNumber(r.run.max_strain)
        << (r.pareto ? "  *     " : "        ") << "  " << stabilityText(r.stable, r.run) << "\n";
  }
}

/// Metadata as "# key: value" lines (scripts/accuracy_plot.py and accuracy.py read them), then one row per setting.
bool writeAccuracyCsv(const std::string& path, const std::vector<std::pair<std::string, std::string>>& metadata,
                      const std::vector<SettingResult>& results) {
  std::ofstream out(path);
  if (!out) return false;
  out << std::setprecision(6);
  for (const auto& [key, value] : metadata) out << "# " << key << ": " << value << "\n";
  out << "integrator,substeps,mean_substeps,cost_ms_per_s,realtime_factor,rms_error_m,max_error_m,max_strain,"
         "rolled_back,recomputed,non_finite,stable,frames_run,pareto,stopped\n";
  for (const SettingResult& r : results) {
    out << core::integratorName(r.integrator) << "," << r.substeps_label << "," << r.mean_substeps << ","
        << r.cost_ms_per_s << "," << kRealTimeCost_ms_per_s / r.cost_ms_per_s << "," << r.error.rms_m << ","
        << r.error.max_m << "," << r.run.max_strain << "," << r.run.rolled_back << "," << r.run.recomputed << ","
        << (r.run.non_finite ? 1 : 0) << "," << (r.stable ? 1 : 0) << "," << r.run.frames_run << ","
        << (r.pareto ? 1 : 0) << "," << csvField(r.run.stopped) << "\n";
  }
  return static_cast<bool>(out);
}

}  // namespace

int runAccuracy(const ToolOptions& options, const core::SceneOptions& scene) {
  const int frames = frameCount(scene, options.seconds);
  const double span_s = frames * scene.frameDuration_s();
  std::cout << "accuracy: scene " << scene.name << " " << gridText(scene.rows, scene.cols) << ", "
            << formatNumber(span_s) << " s (" << frames << " frames at " << formatNumber(scene.frame_rate_hz)
            << " Hz), positions compared at every frame\n";

  // The reference starts finer than every setting of the sweep, so that none is compared with itself.
  ReferenceLimits limits = options.reference;
  const int finest_swept = *std::max_element(options.substep_counts.begin(), options.substep_counts.end());
  limits.first_substeps = std::max(limits.first_substeps, 2 * finest_swept);
  const Reference reference = computeReference(scene, frames, limits, "accuracy:");
  printReference(std::cout, reference, options.reference.tolerance_m, "");
  if (reference.trajectory.empty()) {
    std::cerr << "cloth_bench: no stable reference run: rk4 diverged at every step tried\n";
    return kExitRunFailed;
  }

  const std::vector<Setting> settings = sweepSettings(options, scene);
  long long total_weight = 0, done_weight = 0;
  for (const Setting& s : settings) total_weight += s.progress_weight;
  std::vector<SettingResult> results;
  Progress progress("accuracy");
  for (const Setting& setting : settings) {
    progress.show(100 * done_weight / total_weight,
                  std::string(core::integratorName(setting.integrator)) + " x " + setting.substeps_label);
    results.push_back(runSetting(setting, frames, reference.trajectory, options.min_timing_s));
    done_weight += setting.progress_weight;
  }
  progress.show(100, "done");

  const std::vector<bool> front = paretoFront(costErrors(results));
  for (std::size_t i = 0; i < results.size(); ++i) results[i].pareto = front[i];

  std::cout << "\n";
  std::cout << "cost: CPU time of the frames (" << timingRunsText(options.min_timing_s)
            << "); error: position against the reference over every frame and particle; * = Pareto front "
               "(cost against max error)\n";
  printTable(std::cout, results);
  std::cout << "\n";
  const std::string advice = recommendation(options, results);
  std::cout << advice;

  std::vector<std::pair<std::string, std::string>> metadata = {
      {"scene", scene.name},
      {"grid", gridText(scene.rows, scene.cols)},
      {"seconds", formatNumber(span_s, 6)},
      {"frames", std::to_string(frames)},
      {"frame_rate_hz", formatNumber(scene.frame_rate_hz, 6)},
      {"reference_substeps", std::to_string(reference.substeps)},
      {"reference_converged", reference.converged ? reference.stopped_because : "no (" + reference.stopped_because + ")"},
      {"reference_estimated_error_m", formatNumber(reference.estimated_error_m)},
      {"max_error_m", formatNumber(options.max_error_m)}};
  for (const RefinementStep& step : reference.steps) {
    metadata.push_back({"reference_step", "substeps=" + std::to_string(step.substeps) +
                                              " final_rms_change_m=" +
                                              (step.final_rms_change_m ? formatNumber(*step.final_rms_change_m) : "") +
                                              " diverged=" + (step.diverged ? "1" : "0") +
                                              " cpu_s=" + formatNumber(step.cpu_s)});
  }
  const bool written = writeOutputs(options, "pareto", [&](const std::string& path) {
    return writeAccuracyCsv(path, metadata, results);
  });
  if (!written) return kExitRunFailed;
  // Beside the integrators and substeps, implicit Euler's other knob: its solver's tolerance and cap
  // (--tolerances, --caps), as --solver-sweep measures them. Printed only: --csv and --png hold the table above.
  const auto& integrators = options.integrators;
  if (!options.solver_sweep ||
      std::find(integrators.begin(), integrators.end(), core::IntegratorKind::kImplicitEuler) == integrators.end()) {
    return kExitOk;
  }
  ToolOptions sweep = options;
  sweep.csv_path.clear();
  sweep.png_path.clear();
  std::cout << "\n";
  return runSolverSweep(sweep, scene);
}

}  // namespace cloth_sim::bench
