#include "accuracy_tool.h"

#include "accuracy.h"
#include "number_parsing.h"
#include "scene_override.h"

#include "cloth_sim/core/options.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/state.h"
#include "cloth_sim/io/scene_file.h"

#include <Eigen/Core>

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#ifndef CLOTH_SIM_SCRIPTS_DIR
#error "compile with -DCLOTH_SIM_SCRIPTS_DIR=\"/path/to/scripts\""
#endif

namespace cloth_sim::bench {

namespace {

namespace core = cloth_sim::core;

// ---- constants -----------------------------------------------------------------------------------------------------

constexpr int kExitOk = 0;
constexpr int kExitRunFailed = 1;
constexpr int kExitUsage = 2;

constexpr const char* kAccuracyFlag = "--accuracy";
constexpr const char* kSpatialFlag = "--spatial";
constexpr const char* kStabilityMapFlag = "--stability-map";
constexpr const char* kTermsFlag = "--terms";

constexpr double kDefaultSeconds = 2.0;
constexpr double kDefaultMaxError_m = 1e-3;
/// Substep counts every integrator is tried at (and `auto`, where the scene parser knows it).
const std::vector<int> kDefaultSubstepCounts = {1, 2, 4, 8, 16, 32, 64};
/// A run is timed again (the simulation re-run) until its runs add up to this much CPU, at most
/// kMaxTimingRuns times; the cheapest run is the cost (the others met other processes on the machine).
constexpr double kDefaultMinTiming_s = 0.2;
constexpr int kMaxTimingRuns = 5;
/// A structural strain beyond this (1000 %) is a cloth that has blown up, even if it is still finite.
constexpr double kDivergedStrain = 10.0;
constexpr double kMsPerS = 1e3;
/// One simulated second per CPU second: real time.
constexpr double kRealTimeCost_ms_per_s = 1e3;
/// Weights for the progress percentage: force evaluations per step, implicit Euler's CG iterations counted in.
constexpr int kProgressEvaluations[] = {1, 1, 2, 4, 8};
/// Substeps `auto` is assumed to take, for the progress percentage only.
constexpr int kProgressAutoSubsteps = 16;

// Stability map.
constexpr int kDefaultStabilityGridSide = 8;
/// Stiffness and mass factors applied to the scene's springs and cloth mass.
const std::vector<double> kStiffnessFactors = {1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3};
const std::vector<double> kMassFactors = {1e-2, 1e-1, 1.0, 1e1, 1e2};
/// Initial perturbation, as a fraction of the grid spacing: small enough to stay in the linear regime.
constexpr double kPerturbationFraction = 1e-3;
constexpr unsigned kPerturbationSeed = 12345;
/// A step is unstable when the displacement from rest grows beyond this factor of the initial one.
constexpr double kStabilityGrowthLimit = 10.0;
/// Each test runs this many periods of the highest mode, within [kMinStabilitySteps, kMaxStabilitySteps] steps.
constexpr double kStabilityPeriods = 20.0;
constexpr int kMinStabilitySteps = 50;
constexpr int kMaxStabilitySteps = 5000;
/// The scan of h omega for the measured largest step (bisection refines between scan points).
constexpr double kStabilityMinStepOmega = 1e-2;
constexpr double kStabilityMaxStepOmega = 1e2;
constexpr double kStabilityScanGrowth = 1.5;
constexpr int kPowerIterations = 300;
/// Implicit Euler's solve in the stability map: converged, so that the map shows the method, not the cap.
constexpr double kStabilitySolverTolerance = 1e-10;
constexpr int kStabilitySolverIterations = 1000;

/// Switching a term off changes positions by less than this (m, at any particle in any frame): it is unused.
constexpr double kUnusedTermChange_m = 1e-9;

constexpr double kPi = 3.14159265358979323846;

constexpr const char* kUsage = R"(usage:
  cloth_bench --accuracy --scene NAME_OR_PATH --seconds T [--max-error E | --realtime] [--csv FILE] [--png FILE]
              [--grid RxC] [--set KEY=VALUE ...] [--integrators a,b] [--substeps-list 1,2,4]
              [--reference-budget S] [--reference-tolerance M] [--min-timing S]
      Runs every integrator at 1..64 substeps per frame (and `auto`) for T simulated seconds and compares every
      frame with a converged reference (rk4, its step halved until the final positions change by less than
      --reference-tolerance, default 1e-9 m RMS; the evidence is printed). Reports cost (ms of CPU per simulated
      second), RMS and max position error, max strain and stability; marks the Pareto front (cost against max
      error); ends with a setting to paste: the cheapest with max error <= E (default 1e-3 m), or with
      --realtime the most accurate that runs at least at real time on this machine.
  cloth_bench --spatial --scene NAME_OR_PATH --seconds T --grids 20x20,39x39,77x77 [--csv FILE] [--set ...]
      Each grid (same cloth, same material) against the finest, at the particles they share.
  cloth_bench --stability-map [--scene NAME_OR_PATH] [--grid 8x8] [--csv FILE] [--png FILE]
      Largest stable step of each integrator against stiffness and mass (free cloth, no gravity), undamped and
      with the scene's damping, beside the theory for the highest mode.
  cloth_bench --terms --scene NAME_OR_PATH --seconds T [--csv FILE]
      Cost per frame of the scene with each of its force and collider terms switched off, and how much that
      changes the cloth.

  --scene NAME_OR_PATH   built-in scene name or a .yaml path (default hanging)
  --scenes-dir DIR       where built-in scenes live
  --grid RxC             resample the scene to R x C particles, same cloth and material: spring constants kept
                         (a square cell's sheet stiffness does not depend on its size), mass shared out, air
                         damping per particle and the paper wind coefficient per triangle scaled by the counts
  --set KEY=VALUE        any scene key, as in a scene file (applied before --grid); repeatable
  --seconds T            simulated span (default 2)
  --reference-budget S   CPU seconds the reference may take (default 120)
  --min-timing S         time each setting over at least S CPU seconds of repeated runs (default 0.2; 0: once)
  --png FILE             plot with matplotlib (/usr/bin/python3 scripts/accuracy_plot.py)
)";

// ---- command line --------------------------------------------------------------------------------------------------

enum class Mode { kAccuracy, kSpatial, kStabilityMap, kTerms };

struct GridSize {
  int rows = 0;
  int cols = 0;
};

struct ToolOptions {
  Mode mode = Mode::kAccuracy;
  std::string scene = "hanging";
  std::string scenes_dir;
  std::vector<SceneOverride> overrides;
  std::optional<GridSize> grid;
  std::vector<GridSize> grids;
  double seconds = kDefaultSeconds;
  double max_error_m = kDefaultMaxError_m;
  bool realtime = false;
  std::string csv_path;
  std::string png_path;
  std::vector<core::IntegratorKind> integrators = core::allIntegratorKinds();
  std::vector<int> substep_counts = kDefaultSubstepCounts;
  ReferenceLimits reference;
  double min_timing_s = kDefaultMinTiming_s;
  bool help = false;
};

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

std::optional<GridSize> parseGrid(const std::string& text) {
  const std::size_t x = text.find('x');
  if (x == std::string::npos) return std::nullopt;
  const std::optional<int> rows = parseInt(text.substr(0, x));
  const std::optional<int> cols = parseInt(text.substr(x + 1));
  if (!rows || !cols || *rows < core::OptionLimits::kMinGridSide || *cols < core::OptionLimits::kMinGridSide) {
    return std::nullopt;
  }
  return GridSize{*rows, *cols};
}

void parseToolCommandLine(int argc, char** argv, ToolOptions* options, std::vector<std::string>* errors) {
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      options->help = true;
      continue;
    }
    if (flag == kAccuracyFlag) {
      options->mode = Mode::kAccuracy;
      continue;
    }
    if (flag == kSpatialFlag) {
      options->mode = Mode::kSpatial;
      continue;
    }
    if (flag == kStabilityMapFlag) {
      options->mode = Mode::kStabilityMap;
      continue;
    }
    if (flag == kTermsFlag) {
      options->mode = Mode::kTerms;
      continue;
    }
    if (flag == "--realtime") {
      options->realtime = true;
      continue;
    }
    if (i + 1 >= argc) {
      errors->push_back(flag + ": missing value or unknown option (see --help)");
      break;
    }
    const std::string value = argv[++i];
    const auto positive = [&](double* out) {
      const std::optional<double> number = parseDouble(value);
      if (!number || *number <= 0) {
        errors->push_back(flag + " " + value + ": expected a number > 0");
      } else {
        *out = *number;
      }
    };
    if (flag == "--scene") {
      options->scene = value;
    } else if (flag == "--scenes-dir") {
      options->scenes_dir = value;
    } else if (flag == "--set") {
      const std::size_t equals = value.find('=');
      if (equals == std::string::npos || equals == 0) {
        errors->push_back("--set " + value + ": expected KEY=VALUE");
      } else {
        options->overrides.push_back({"--set", value.substr(0, equals), value.substr(equals + 1)});
      }
    } else if (flag == "--grid") {
      options->grid = parseGrid(value);
      if (!options->grid) errors->push_back("--grid " + value + ": expected ROWSxCOLS, each >= 2");
    } else if (flag == "--grids") {
      for (const std::string& item : splitList(value)) {
        const std::optional<GridSize> grid = parseGrid(item);
        if (!grid) {
          errors->push_back("--grids " + value + ": expected ROWSxCOLS,ROWSxCOLS,...");
          break;
        }
        options->grids.push_back(*grid);
      }
    } else if (flag == "--seconds") {
      positive(&options->seconds);
    } else if (flag == "--max-error") {
      positive(&options->max_error_m);
    } else if (flag == "--reference-budget") {
      positive(&options->reference.cpu_budget_s);
    } else if (flag == "--reference-tolerance") {
      positive(&options->reference.tolerance_m);
    } else if (flag == "--min-timing") {
      const std::optional<double> number = parseDouble(value);
      if (!number || *number < 0) errors->push_back(flag + " " + value + ": expected a number >= 0");
      if (number) options->min_timing_s = *number;
    } else if (flag == "--csv") {
      options->csv_path = value;
    } else if (flag == "--png") {
      options->png_path = value;
    } else if (flag == "--integrators") {
      options->integrators.clear();
      for (const std::string& name : splitList(value)) {
        core::IntegratorKind kind;
        if (!core::parseIntegratorName(name, &kind)) {
          errors->push_back("--integrators: unknown '" + name + "' (known: " + core::integratorNameList() + ")");
        } else {
          options->integrators.push_back(kind);
        }
      }
    } else if (flag == "--substeps-list") {
      options->substep_counts.clear();
      for (const std::string& item : splitList(value)) {
        const std::optional<int> count = parseInt(item);
        if (!count || *count < 1 || *count > core::OptionLimits::kMaxSubsteps) {
          errors->push_back("--substeps-list: '" + item + "' is not a substep count in [1, 10000]");
        } else {
          options->substep_counts.push_back(*count);
        }
      }
    } else {
      errors->push_back("unknown option '" + flag + "' (see --help)");
    }
  }
  if (options->mode == Mode::kSpatial && options->grids.size() < 2) {
    errors->push_back("--spatial needs --grids with at least two grids, coarse first (e.g. 20x20,39x39,77x77)");
  }
}

// ---- scenes --------------------------------------------------------------------------------------------------------

bool sceneKeyKnown(const std::string& key) {
  const std::vector<std::string>& keys = core::sceneKeys();
  return std::find(keys.begin(), keys.end(), key) != keys.end();
}

/// Applies KEY=VALUE if the scene parser accepts it; false (scene unchanged) if not, e.g. a key or value this
/// build does not know yet.
bool tryOverride(const std::string& key, const std::string& value, core::SceneOptions* scene) {
  core::SceneOptions trial = *scene;
  std::vector<std::string> errors;
  applyOverride({"--set", key, value}, &trial, &errors);
  if (!errors.empty() || !core::validateSceneOptions(trial).empty()) return false;
  *scene = trial;
  return true;
}

/// The same cloth at rows x cols: size, mass and spring constants kept (a square cell's sheet stiffness per unit
/// width is its spring's stiffness, whatever the cell size), air damping per particle and the paper wind per
/// triangle scaled so that the cloth as a whole feels the same. Bend springs act across two cells and do not scale
/// this simply: they are kept, a small difference next to the structural springs.
void resampleScene(const GridSize& grid, core::SceneOptions* scene) {
  const double particle_ratio =
      static_cast<double>(scene->rows * scene->cols) / static_cast<double>(grid.rows * grid.cols);
  const double triangle_ratio = static_cast<double>((scene->rows - 1) * (scene->cols - 1)) /
                                static_cast<double>((grid.rows - 1) * (grid.cols - 1));
  scene->air_damping_N_s_per_m *= particle_ratio;
  if (scene->wind.model == core::WindModel::kPaper) scene->wind.paper_coefficient_N_s_per_m *= triangle_ratio;
  scene->rows = grid.rows;
  scene->cols = grid.cols;
}

bool buildToolScene(const ToolOptions& options, const std::optional<GridSize>& grid, core::SceneOptions* scene,
                    std::vector<std::string>* errors) {
  if (!core::loadSceneFile(core::resolveScenePath(options.scene, options.scenes_dir), scene, errors)) return false;
  for (const SceneOverride& entry : options.overrides) applyOverride(entry, scene, errors);
  if (!errors->empty()) return false;
  if (grid) resampleScene(*grid, scene);
  for (const std::string& problem : core::validateSceneOptions(*scene)) errors->push_back(problem);
  return errors->empty();
}

/// Fixed substeps stay fixed: where the build knows `guard_retries`, the guard's recomputations are switched off.
bool disableGuardRetries(core::SceneOptions* scene) {
  return sceneKeyKnown("guard_retries") && tryOverride("guard_retries", "false", scene);
}

int frameCount(const core::SceneOptions& scene, double seconds) {
  return std::max(1, static_cast<int>(std::lround(seconds * scene.frame_rate_hz)));
}

std::string gridText(int rows, int cols) { return std::to_string(rows) + "x" + std::to_string(cols); }

std::string substepsText(const core::SceneOptions& scene) {
  return scene.autoSubsteps() ? std::string(core::kAutoSubstepsName) : std::to_string(scene.substeps);
}

/// A percentage on stderr: rewritten in place on a terminal, one line per ten percent in a log.
class Progress {
 public:
  explicit Progress(std::string what) : what_(std::move(what)), terminal_(isatty(STDERR_FILENO) != 0) {}
  void show(long long percent, const std::string& doing) {
    constexpr long long kLogStepPercent = 10;
    if (terminal_) {
      std::cerr << "\rcloth_bench: " << what_ << " " << std::setw(3) << percent << "% (" << doing << ")"
                << std::string(kPadding, ' ') << (percent >= 100 ? "\n" : "") << std::flush;
    } else if (percent >= next_logged_) {
      std::cerr << "cloth_bench: " << what_ << " " << percent << "% (" << doing << ")\n";
      next_logged_ = (percent / kLogStepPercent + 1) * kLogStepPercent;
    }
  }

 private:
  static constexpr std::size_t kPadding = 12;  ///< clears the rest of a longer previous line
  std::string what_;
  bool terminal_;
  long long next_logged_ = 0;
};

// ---- running -------------------------------------------------------------------------------------------------------

double cpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

/// One simulated span of a setting.
struct SpanRun {
  Trajectory trajectory;  ///< positions after every frame (when recorded)
  double cpu_s = 0.0;     ///< CPU time inside advanceFrame
  int frames_run = 0;
  long long substeps_total = 0;
  double max_strain = 0.0;
  int rolled_back = 0;
  int recomputed = 0;
  bool non_finite = false;
  bool diverged = false;
  std::string stopped;  ///< why it ended early
};

/// Runs `frames` frames, stopping at the first that diverges: not finite or beyond the guard's box, rolled back,
/// strained beyond kDivergedStrain, or (fixed substeps) recomputed with more substeps by the guard.
SpanRun simulateSpan(const core::SceneOptions& scene, int frames, bool record, bool fixed_substeps) {
  SpanRun run;
  core::Simulation sim(scene);
  if (record) run.trajectory.reserve(static_cast<std::size_t>(frames));
  for (int frame = 0; frame < frames; ++frame) {
    const double start_s = cpuSeconds();
    const core::FrameReport report = sim.advanceFrame();
    run.cpu_s += cpuSeconds() - start_s;
    ++run.frames_run;
    run.substeps_total += report.substeps_used;
    run.max_strain = std::max(run.max_strain, report.max_strain);
    if (!report.stable) ++run.rolled_back;
    if (report.recomputed) ++run.recomputed;
    if (!sim.state().positions_m.allFinite() || !sim.state().velocities_m_per_s.allFinite()) run.non_finite = true;
    if (record) run.trajectory.push_back(sim.state().positions_m);

    std::ostringstream reason;
    if (run.non_finite || !core::isFiniteAndBounded(sim.state(), core::Simulation::kDivergenceBound_m)) {
      reason << "not finite or beyond " << core::Simulation::kDivergenceBound_m << " m";
    } else if (!report.stable) {
      reason << "rolled back (" << report.rejection << ")";
    } else if (fixed_substeps && report.recomputed) {
      reason << "recomputed by the guard with " << report.substeps_used << " substeps";
    } else if (report.max_strain > kDivergedStrain) {
      reason << "strain " << report.max_strain << " > " << kDivergedStrain;
    }
    if (!reason.str().empty()) {
      run.diverged = true;
      run.stopped = "frame " + std::to_string(frame + 1) + ": " + reason.str();
      break;
    }
  }
  return run;
}

/// Reference runs: rk4 at the given substeps, guard retries off where possible.
Reference computeReference(const core::SceneOptions& scene, int frames, const ReferenceLimits& given,
                           const std::string& label) {
  core::SceneOptions base = scene;
  base.integrator = core::IntegratorKind::kRK4;
  disableGuardRetries(&base);
  ReferenceLimits limits = given;
  limits.frame_s = scene.frameDuration_s();
  limits.max_substeps = std::min(limits.max_substeps, core::OptionLimits::kMaxSubsteps);
  const auto run = [&](int substeps) {
    core::SceneOptions options = base;
    options.substeps = substeps;
    SpanRun span = simulateSpan(options, frames, true, true);
    std::cerr << "cloth_bench: " << label << " reference rk4 x " << substeps << ": " << std::setprecision(3)
              << span.cpu_s << " s CPU" << (span.diverged ? " (diverged: " + span.stopped + ")" : "") << "\n";
    return RefinementRun{std::move(span.trajectory), span.diverged, span.cpu_s};
  };
  return convergeReference(run, limits);
}

std::string formatNumber(double value, int digits = 3) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream out;
  out << std::setprecision(digits) << value;
  return out.str();
}

/// The evidence that the reference converged, one line per run.
void printReference(std::ostream& out, const Reference& reference, double tolerance_m, const std::string& prefix) {
  out << prefix << "reference: rk4, step halved until the final positions change by < " << formatNumber(tolerance_m)
      << " m RMS\n";
  std::optional<double> previous_change;
  for (const RefinementStep& step : reference.steps) {
    out << prefix << "  substeps " << std::setw(5) << step.substeps << "  step " << std::setw(9)
        << formatNumber(step.step_s) << " s  ";
    if (step.diverged) {
      out << "diverged";
    } else if (!step.final_rms_change_m) {
      out << "first stable run";
    } else {
      out << "final RMS change " << std::setw(9) << formatNumber(*step.final_rms_change_m) << " m, largest frame "
          << formatNumber(*step.max_rms_change_m) << " m";
      if (previous_change) {
        const std::optional<double> order = observedOrder(*previous_change, *step.final_rms_change_m);
        if (order) out << ", observed order " << formatNumber(*order, 2);
      }
      previous_change = step.final_rms_change_m;
    }
    out << "  (" << formatNumber(step.cpu_s) << " s CPU)\n";
  }
  out << prefix << "  => " << (reference.converged ? reference.stopped_because : "NOT converged (" + reference.stopped_because + ")")
      << "; kept " << reference.substeps << " substeps, estimated error " << formatNumber(reference.estimated_error_m)
      << " m RMS\n";
}

// ---- --accuracy ----------------------------------------------------------------------------------------------------

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

/// Every integrator x substep count, and `auto` where the parser knows it (noted in *notes otherwise).
std::vector<Setting> sweepSettings(const ToolOptions& options, const core::SceneOptions& scene,
                                   std::vector<std::string>* notes) {
  std::vector<Setting> settings;
  bool auto_known = true;
  for (core::IntegratorKind kind : options.integrators) {
    const int evaluations = kProgressEvaluations[static_cast<int>(kind)];
    for (int substeps : options.substep_counts) {
      core::SceneOptions s = scene;
      s.integrator = kind;
      s.substeps = substeps;
      disableGuardRetries(&s);
      settings.push_back({kind, std::to_string(substeps), s, true, substeps * evaluations});
    }
    core::SceneOptions s = scene;
    s.integrator = kind;
    if (tryOverride("substeps", core::kAutoSubstepsName, &s)) {
      settings.push_back({kind, core::kAutoSubstepsName, s, false, kProgressAutoSubsteps * evaluations});
    } else {
      auto_known = false;
    }
  }
  if (!auto_known) notes->push_back("substeps: auto is not known to this build's scene parser: left out");
  if (!sceneKeyKnown("guard_retries")) {
    notes->push_back("guard_retries is not known to this build: a fixed setting that the guard had to recompute "
                     "counts as diverged");
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
  result.cost_ms_per_s = best_cpu_s * kMsPerS / simulated_s;
  return result;
}

std::string stabilityText(const SettingResult& r) {
  std::ostringstream out;
  out << (r.stable ? "ok" : "DIVERGED " + r.run.stopped);
  if (r.run.rolled_back > 0 || r.run.recomputed > 0) {
    out << " (rolled back " << r.run.rolled_back << ", recomputed " << r.run.recomputed << ")";
  }
  return out.str();
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
        << (r.pareto ? "  *     " : "        ") << "  " << stabilityText(r) << "\n";
  }
}

std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
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

/// Runs scripts/accuracy_plot.py on a CSV; false (with a message) if it fails.
bool plot(const std::string& csv_path, const std::string& png_path, const std::string& kind) {
  const std::string script = std::string(CLOTH_SIM_SCRIPTS_DIR) + "/accuracy_plot.py";
  if (!std::filesystem::exists(script)) {
    std::cerr << "cloth_bench: no plot: " << script << " not found (it is in the source tree, not installed)\n";
    return false;
  }
  const std::string command =
      "/usr/bin/python3 '" + script + "' " + kind + " '" + csv_path + "' '" + png_path + "'";
  if (std::system(command.c_str()) != 0) {
    std::cerr << "cloth_bench: the plot failed (needs python3-matplotlib): " << command << "\n";
    return false;
  }
  std::cerr << "cloth_bench: wrote " << png_path << "\n";
  return true;
}

/// Writes the CSV where asked, and the PNG through it (a temporary CSV next to the PNG when none was asked for).
bool writeOutputs(const ToolOptions& options, const std::string& plot_kind,
                  const std::function<bool(const std::string&)>& write_csv) {
  bool ok = true;
  if (!options.csv_path.empty()) {
    ok = write_csv(options.csv_path);
    if (ok) std::cerr << "cloth_bench: wrote " << options.csv_path << "\n";
    else std::cerr << "cloth_bench: cannot write " << options.csv_path << "\n";
  }
  if (!options.png_path.empty()) {
    const bool temporary = options.csv_path.empty();
    const std::string csv = temporary ? options.png_path + ".csv" : options.csv_path;
    if (temporary && !write_csv(csv)) {
      std::cerr << "cloth_bench: cannot write " << csv << "\n";
      return false;
    }
    ok = plot(csv, options.png_path, plot_kind) && ok;
    if (temporary) std::remove(csv.c_str());
  }
  return ok;
}

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

  std::vector<std::string> notes;
  const std::vector<Setting> settings = sweepSettings(options, scene, &notes);
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
  for (const std::string& note : notes) std::cout << "note: " << note << "\n";
  std::cout << "cost: CPU time of the frames (best of up to " << kMaxTimingRuns
            << " runs); error: position against the reference over every frame and particle; * = Pareto front "
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
  for (const std::string& note : notes) metadata.push_back({"note", note});
  const bool written = writeOutputs(options, "pareto", [&](const std::string& path) {
    return writeAccuracyCsv(path, metadata, results);
  });
  return written ? kExitOk : kExitRunFailed;
}

// ---- --spatial -----------------------------------------------------------------------------------------------------

int runSpatial(const ToolOptions& options) {
  struct GridRun {
    GridSize grid;
    Reference reference;
  };
  std::vector<GridRun> runs;
  int frames = 0;
  for (const GridSize& grid : options.grids) {
    core::SceneOptions scene;
    std::vector<std::string> errors;
    if (!buildToolScene(options, grid, &scene, &errors)) {
      for (const std::string& e : errors) std::cerr << "cloth_bench: " << gridText(grid.rows, grid.cols) << ": " << e << "\n";
      return kExitUsage;
    }
    frames = frameCount(scene, options.seconds);
    const std::string label = "spatial " + gridText(grid.rows, grid.cols);
    runs.push_back({grid, computeReference(scene, frames, options.reference, label)});
    printReference(std::cout, runs.back().reference, options.reference.tolerance_m,
                   gridText(grid.rows, grid.cols) + ": ");
  }
  const GridRun& finest = runs.back();
  std::cout << "\nspatial error against " << gridText(finest.grid.rows, finest.grid.cols)
            << " (same cloth and material), at the particles the grids share, over every frame\n";
  std::cout << std::left << std::setw(10) << "grid" << std::right << std::setw(14) << "RMS error m" << std::setw(14)
            << "max error m" << std::setw(18) << "time error est m" << "\n";
  std::ostringstream csv;
  csv << "grid,rows,cols,reference_substeps,reference_converged,time_error_estimate_m,rms_error_m,max_error_m\n";
  for (const GridRun& run : runs) {
    const std::vector<int> map =
        nestedParticleMap(run.grid.rows, run.grid.cols, finest.grid.rows, finest.grid.cols);
    std::optional<TrajectoryError> error;
    if (!map.empty() && !run.reference.trajectory.empty() && !finest.reference.trajectory.empty()) {
      error = compareTrajectories(run.reference.trajectory, finest.reference.trajectory, map);
    }
    const std::string name = gridText(run.grid.rows, run.grid.cols);
    std::cout << std::left << std::setw(10) << name << std::right << std::setw(14)
              << (error ? formatNumber(error->rms_m) : "-") << std::setw(14)
              << (error ? formatNumber(error->max_m) : "-") << std::setw(18)
              << formatNumber(run.reference.estimated_error_m) << (map.empty() ? "  (grids do not nest)" : "")
              << "\n";
    csv << name << "," << run.grid.rows << "," << run.grid.cols << "," << run.reference.substeps << ","
        << (run.reference.converged ? 1 : 0) << "," << run.reference.estimated_error_m << ","
        << (error ? formatNumber(error->rms_m, 6) : "") << "," << (error ? formatNumber(error->max_m, 6) : "") << "\n";
  }
  if (!options.csv_path.empty()) {
    std::ofstream out(options.csv_path);
    out << "# scene: " << options.scene << "\n# seconds: " << options.seconds << "\n# frames: " << frames << "\n"
        << csv.str();
    if (!out) {
      std::cerr << "cloth_bench: cannot write " << options.csv_path << "\n";
      return kExitRunFailed;
    }
  }
  return kExitOk;
}

// ---- --stability-map -----------------------------------------------------------------------------------------------

/// The highest mode of the cloth linearised at rest: omega^2 = w'Kw / w'Mw and its damping rate w'Cw / w'Mw, by
/// power iteration on M^-1 K (K and C from the force model's differential: the real stiffness, not a formula).
struct HighestMode {
  double omega_rad_per_s = 0.0;
  double damping_rate_per_s = 0.0;
};

HighestMode highestMode(core::Simulation& sim) {
  core::ClothForceModel& model = sim.forceModel();
  const core::ClothState& rest = sim.state();
  const Eigen::VectorXd& mass = model.mass_kg();
  model.linearize(rest.positions_m, Eigen::Matrix3Xd::Zero(3, rest.particleCount()), 0.0);
  std::mt19937 random(kPerturbationSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::Matrix3Xd w(3, rest.particleCount());
  for (Eigen::Index i = 0; i < w.size(); ++i) w.data()[i] = uniform(random);
  Eigen::Matrix3Xd df, zero = Eigen::Matrix3Xd::Zero(3, rest.particleCount());
  const auto mass_norm = [&](const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
    return (a.cwiseProduct(b).colwise().sum().transpose().cwiseProduct(mass)).sum();
  };
  double lambda = 0.0;
  for (int k = 0; k < kPowerIterations; ++k) {
    model.stiffnessProduct(w, df);  // df = -K w
    Eigen::Matrix3Xd next = -df * mass.cwiseInverse().asDiagonal();
    lambda = -(w.cwiseProduct(df)).sum() / mass_norm(w, w);
    w = next / std::sqrt(mass_norm(next, next));
  }
  model.forceDifferential(zero, w, df);  // df = -C w
  HighestMode mode;
  mode.omega_rad_per_s = std::sqrt(std::max(lambda, 0.0));
  // Exactly 0 undamped (not -0: the tables print it).
  mode.damping_rate_per_s = std::max(0.0, -(w.cwiseProduct(df)).sum() / mass_norm(w, w));
  return mode;
}

/// True when `kind` at step h keeps a small random perturbation of the resting cloth from growing beyond
/// kStabilityGrowthLimit times its start (and finite) over kStabilityPeriods periods of the highest mode.
bool stableAt(core::Simulation& sim, core::IntegratorKind kind, double omega, double step_s) {
  core::SolverOptions solver;
  solver.tolerance = kStabilitySolverTolerance;
  solver.max_iterations = kStabilitySolverIterations;
  const std::unique_ptr<core::Integrator> integrator = core::makeIntegrator(kind, solver);
  const Eigen::Matrix3Xd& rest = sim.grid().rest_positions_m;
  const double spacing_m = sim.options().width_m / (sim.options().cols - 1);
  std::mt19937 random(kPerturbationSeed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  core::ClothState state = sim.state();
  for (Eigen::Index i = 0; i < state.positions_m.size(); ++i) {
    state.positions_m.data()[i] = rest.data()[i] + kPerturbationFraction * spacing_m * uniform(random);
  }
  state.velocities_m_per_s.setZero();
  const double initial_m = rmsDistance(state.positions_m, rest);
  const double period_s = 2.0 * kPi / omega;
  const int steps = std::clamp(static_cast<int>(std::ceil(kStabilityPeriods * period_s / step_s)), kMinStabilitySteps,
                               kMaxStabilitySteps);
  for (int k = 0; k < steps; ++k) {
    integrator->step(sim.forceModel(), step_s, state);
    if (!state.positions_m.allFinite() || !state.velocities_m_per_s.allFinite()) return false;
    if (rmsDistance(state.positions_m, rest) > kStabilityGrowthLimit * initial_m) return false;
  }
  return true;
}

int runStabilityMap(const ToolOptions& options) {
  const GridSize grid = options.grid.value_or(GridSize{kDefaultStabilityGridSide, kDefaultStabilityGridSide});
  core::SceneOptions base;
  std::vector<std::string> errors;
  if (!buildToolScene(options, grid, &base, &errors)) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  // A free cloth at rest: no pins, gravity, wind or colliders, so that only the springs (and damping) act.
  base.pins.clear();
  base.pin_positions_m.clear();
  base.pin_travel_time_s = 0.0;
  base.pin_motion_amplitude_m.setZero();
  base.gravity_m_per_s2.setZero();
  base.wind_enabled = false;
  base.colliders = core::ColliderSet();

  struct Point {
    std::string sweep;
    double factor;
  };
  std::vector<Point> points;
  for (double f : kStiffnessFactors) points.push_back({"stiffness", f});
  for (double f : kMassFactors) points.push_back({"mass", f});

  std::ostringstream csv;
  csv << std::setprecision(6);
  csv << "integrator,damped,sweep,factor,structural_stiffness_N_per_m,particle_mass_kg,omega_max_rad_per_s,"
         "omega_formula_rad_per_s,damping_rate_per_s,h_measured_s,h_theory_s,h_measured_omega,h_theory_omega,"
         "measured_capped,theory_capped\n";
  std::cout << "stability map: " << gridText(grid.rows, grid.cols) << " free cloth at rest, perturbed by "
            << kPerturbationFraction << " of a cell; unstable when the displacement grows " << kStabilityGrowthLimit
            << "x within " << kStabilityPeriods << " periods of the highest mode (" << kMinStabilitySteps << "-"
            << kMaxStabilitySteps << " steps)\n";
  std::cout << std::left << std::setw(17) << "integrator" << std::setw(8) << "damped" << std::setw(11) << "sweep"
            << std::right << std::setw(10) << "K N/m" << std::setw(11) << "m kg" << std::setw(10) << "omega"
            << std::setw(10) << "c 1/s" << std::setw(12) << "h meas s" << std::setw(12) << "h theory s"
            << std::setw(9) << "h w meas" << std::setw(9) << "h w th" << "\n";
  const std::size_t total = options.integrators.size() * 2 * points.size();
  Progress progress("stability map");
  std::size_t done = 0;
  for (core::IntegratorKind kind : options.integrators) {
    for (bool damped : {false, true}) {
      for (const Point& point : points) {
        progress.show(static_cast<long long>(100 * done / total), std::string(core::integratorName(kind)) +
                                                                      (damped ? " damped " : " undamped ") +
                                                                      point.sweep);
        ++done;
        core::SceneOptions scene = base;
        for (core::SpringOptions& spring : scene.springs) {
          if (point.sweep == "stiffness") spring.stiffness_N_per_m *= point.factor;
          if (!damped) spring.damping_N_s_per_m = 0.0;
        }
        if (point.sweep == "mass") scene.mass_kg *= point.factor;
        if (!damped) scene.air_damping_N_s_per_m = 0.0;
        core::Simulation sim(scene);
        const HighestMode mode = highestMode(sim);
        const double particle_mass_kg = scene.mass_kg / (scene.rows * scene.cols);
        const auto& springs = scene.springs;
        const double k_structural = springs[static_cast<int>(core::SpringKind::kStructural)].stiffness_N_per_m;
        const double k_shear = springs[static_cast<int>(core::SpringKind::kShear)].enabled
                                   ? springs[static_cast<int>(core::SpringKind::kShear)].stiffness_N_per_m
                                   : 0.0;
        // The in-plane mode alternating from column to column on a square grid: 4 k_structural from the two
        // springs along the row, 4 k_shear from the four diagonals (each 1/2 along x, stretched twice over).
        const double omega_formula = std::sqrt(4.0 * (k_structural + k_shear) / particle_mass_kg);
        const double omega = mode.omega_rad_per_s;
        const double h_min = kStabilityMinStepOmega / omega, h_max = kStabilityMaxStepOmega / omega;
        const double measured = largestStableStep([&](double h) { return stableAt(sim, kind, omega, h); }, h_min,
                                                  h_max, kStabilityScanGrowth);
        const double theory = theoreticalStableStep(kind, omega, mode.damping_rate_per_s);
        const bool measured_capped = measured >= h_max;
        const bool theory_capped = theory >= theoreticalStepCap_s(omega);
        csv << core::integratorName(kind) << "," << (damped ? 1 : 0) << "," << point.sweep << "," << point.factor
            << "," << k_structural << "," << particle_mass_kg << "," << omega << "," << omega_formula << ","
            << mode.damping_rate_per_s << "," << measured << "," << theory << "," << measured * omega << ","
            << theory * omega << "," << (measured_capped ? 1 : 0) << "," << (theory_capped ? 1 : 0) << "\n";
        std::cout << std::left << std::setw(17) << core::integratorName(kind) << std::setw(8)
                  << (damped ? "yes" : "no") << std::setw(11) << point.sweep << std::right << std::setw(10)
                  << formatNumber(k_structural) << std::setw(11) << formatNumber(particle_mass_kg) << std::setw(10)
                  << formatNumber(omega) << std::setw(10) << formatNumber(mode.damping_rate_per_s) << std::setw(12)
                  << (measured_capped ? ">" : "") + formatNumber(measured) << std::setw(12)
                  << (theory_capped ? ">" : "") + formatNumber(theory) << std::setw(9)
                  << formatNumber(measured * omega) << std::setw(9) << formatNumber(theory * omega) << "\n";
      }
    }
  }
  progress.show(100, "done");
  const bool written = writeOutputs(options, "stability", [&](const std::string& path) {
    std::ofstream out(path);
    out << "# grid: " << gridText(grid.rows, grid.cols) << "\n# scene: " << options.scene << "\n" << csv.str();
    return static_cast<bool>(out);
  });
  return written ? kExitOk : kExitRunFailed;
}

// ---- --terms -------------------------------------------------------------------------------------------------------

struct Term {
  std::string name;
  std::function<void(core::SceneOptions*)> switch_off;
};

/// The force and collider terms the scene has switched on.
std::vector<Term> termsOf(const core::SceneOptions& scene) {
  std::vector<Term> terms;
  for (int k = 0; k < core::kSpringKindCount; ++k) {
    const core::SpringOptions& spring = scene.springs[k];
    if (!spring.enabled || (spring.stiffness_N_per_m == 0.0 && spring.damping_N_s_per_m == 0.0)) continue;
    const std::string kind = core::springKindName(static_cast<core::SpringKind>(k));
    terms.push_back({kind + " springs", [k](core::SceneOptions* s) { s->springs[k].enabled = false; }});
    if (spring.damping_N_s_per_m > 0.0) {
      terms.push_back({kind + " damping", [k](core::SceneOptions* s) { s->springs[k].damping_N_s_per_m = 0.0; }});
    }
  }
  if (!scene.gravity_m_per_s2.isZero()) {
    terms.push_back({"gravity", [](core::SceneOptions* s) { s->gravity_m_per_s2.setZero(); }});
  }
  if (scene.air_damping_N_s_per_m > 0.0) {
    terms.push_back({"air damping", [](core::SceneOptions* s) { s->air_damping_N_s_per_m = 0.0; }});
  }
  if (scene.wind_enabled) terms.push_back({"wind", [](core::SceneOptions* s) { s->wind_enabled = false; }});
  for (std::size_t i = 0; i < scene.colliders.planes.size(); ++i) {
    terms.push_back({"plane " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.planes.erase(s->colliders.planes.begin() + static_cast<long>(i));
                     }});
  }
  for (std::size_t i = 0; i < scene.colliders.spheres.size(); ++i) {
    terms.push_back({"sphere " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.spheres.erase(s->colliders.spheres.begin() + static_cast<long>(i));
                     }});
  }
  for (std::size_t i = 0; i < scene.colliders.boxes.size(); ++i) {
    terms.push_back({"box " + std::to_string(i), [i](core::SceneOptions* s) {
                       s->colliders.boxes.erase(s->colliders.boxes.begin() + static_cast<long>(i));
                     }});
  }
  return terms;
}

/// CPU ms per frame, best of a few runs.
double msPerFrame(const core::SceneOptions& scene, int frames, double min_timing_s, SpanRun* first) {
  *first = simulateSpan(scene, frames, true, false);
  double best_s = first->cpu_s, total_s = first->cpu_s;
  for (int runs = 1; runs < kMaxTimingRuns && total_s < min_timing_s; ++runs) {
    const double cpu_s = simulateSpan(scene, frames, false, false).cpu_s;
    best_s = std::min(best_s, cpu_s);
    total_s += cpu_s;
  }
  return best_s * kMsPerS / std::max(1, first->frames_run);
}

int runTerms(const ToolOptions& options, const core::SceneOptions& scene) {
  const int frames = frameCount(scene, options.seconds);
  SpanRun baseline;
  const double baseline_ms = msPerFrame(scene, frames, options.min_timing_s, &baseline);
  std::cout << "terms: scene " << scene.name << " " << gridText(scene.rows, scene.cols) << ", "
            << core::integratorName(scene.integrator) << " x " << substepsText(scene) << ", " << frames
            << " frames: " << formatNumber(baseline_ms) << " ms CPU per frame with every term\n";
  std::cout << std::left << std::setw(20) << "switched off" << std::right << std::setw(12) << "ms/frame" << std::setw(12)
            << "saves ms" << std::setw(16) << "max change m" << "  used\n";
  std::ostringstream csv;
  csv << std::setprecision(6)
      << "scene,term,ms_per_frame_all,ms_per_frame_without,max_change_m,rms_change_m,used,frames_run,stopped\n";
  if (baseline.diverged) {
    std::cout << "note: the scene as shipped stopped at " << baseline.stopped << "\n";
  }
  for (const Term& term : termsOf(scene)) {
    core::SceneOptions without = scene;
    term.switch_off(&without);
    SpanRun run;
    const double ms = msPerFrame(without, frames, options.min_timing_s, &run);
    const TrajectoryError change = compareTrajectories(run.trajectory, baseline.trajectory);
    // A run that stopped early (the cloth fell away without gravity's counterpart, say) changed things.
    const bool used = !(change.max_m < kUnusedTermChange_m) || run.frames_run != baseline.frames_run;
    std::cout << std::left << std::setw(20) << term.name << std::right << std::setw(12) << formatNumber(ms)
              << std::setw(12) << formatNumber(baseline_ms - ms) << std::setw(16) << formatNumber(change.max_m)
              << "  " << (used ? "yes" : "NO: switching it off changes nothing")
              << (run.diverged ? " (without it: " + run.stopped + ")" : "") << "\n";
    csv << scene.name << "," << term.name << "," << baseline_ms << "," << ms << "," << change.max_m << ","
        << change.rms_m << "," << (used ? 1 : 0) << "," << run.frames_run << "," << csvField(run.stopped) << "\n";
  }
  if (!options.csv_path.empty()) {
    std::ofstream out(options.csv_path);
    out << csv.str();
    if (!out) {
      std::cerr << "cloth_bench: cannot write " << options.csv_path << "\n";
      return kExitRunFailed;
    }
  }
  return kExitOk;
}

}  // namespace

bool isAccuracyToolCommand(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == kAccuracyFlag || flag == kSpatialFlag || flag == kStabilityMapFlag || flag == kTermsFlag) return true;
  }
  return false;
}

int runAccuracyTool(int argc, char** argv, const std::string& default_scenes_dir) {
  ToolOptions options;
  options.scenes_dir = default_scenes_dir;
  std::vector<std::string> errors;
  parseToolCommandLine(argc, argv, &options, &errors);
  if (options.help) {
    std::cout << kUsage;
    return errors.empty() ? kExitOk : kExitUsage;
  }
  if (!errors.empty()) {
    for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
    return kExitUsage;
  }
  try {
    if (options.mode == Mode::kSpatial) return runSpatial(options);
    if (options.mode == Mode::kStabilityMap) return runStabilityMap(options);
    core::SceneOptions scene;
    if (!buildToolScene(options, options.grid, &scene, &errors)) {
      for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
      return kExitUsage;
    }
    return options.mode == Mode::kTerms ? runTerms(options, scene) : runAccuracy(options, scene);
  } catch (const std::exception& e) {
    std::cerr << "cloth_bench: run failed: " << e.what() << "\n";
    return kExitRunFailed;
  }
}

}  // namespace cloth_sim::bench
