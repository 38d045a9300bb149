// What cloth_bench's measuring modes share: their options (one command line for all of them, parsed in
// accuracy_tool.cpp), the scene as they build it, progress, the rk4 reference, number formatting and output files.
// Each mode lives in its own file: mode_accuracy.cpp, mode_spatial.cpp, mode_stability_map.cpp, mode_terms.cpp,
// mode_solver_sweep.cpp.
#pragma once

#include "accuracy.h"
#include "bench_common.h"
#include "span_run.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/options.h"

#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace cloth_sim::bench {

enum class Mode { kAccuracy, kSpatial, kStabilityMap, kTerms, kSolverSweep };

/// A setting is timed again (the simulation re-run) until its runs add up to ToolOptions::min_timing_s of CPU, at
/// most this many times; the cheapest run is the cost (the others met other processes on the machine).
constexpr int kMaxTimingRuns = 5;
/// How the cost columns were timed, for the tables' legends: "best of up to 5 runs", or "one run" where
/// --min-timing 0 asked for a single run.
inline std::string timingRunsText(double min_timing_s) {
  return min_timing_s > 0.0 ? "best of up to " + std::to_string(kMaxTimingRuns) + " runs" : "one run";
}
using core::kMillisecondsPerSecond;

struct GridSize {
  int rows = 0;
  int cols = 0;
};

/// Everything the modes' command line says, parsed once (accuracy_tool.cpp).
struct ToolOptions {
  static constexpr double kDefaultSeconds = 2.0;
  static constexpr double kDefaultMaxError_m = 1e-3;
  static constexpr double kDefaultMinTiming_s = 0.2;

  Mode mode = Mode::kAccuracy;
  std::string scene = "hanging";
  std::string scenes_dir;
  std::vector<SceneOverride> overrides;
  bool dynamic = false;  ///< released flat (makeDynamic), after the overrides and before --grid
  std::optional<GridSize> grid;
  std::vector<GridSize> grids;
  double seconds = kDefaultSeconds;
  double max_error_m = kDefaultMaxError_m;
  bool realtime = false;
  std::string csv_path;
  std::string png_path;
  std::vector<core::IntegratorKind> integrators = core::allIntegratorKinds();
  /// Substep counts every integrator is tried at (and `auto`).
  std::vector<int> substep_counts = {1, 2, 4, 8, 16, 32, 64};
  ReferenceLimits reference;
  double min_timing_s = kDefaultMinTiming_s;
  // --solver-sweep (and --accuracy, after its integrators, unless --no-solver-sweep)
  bool solver_sweep = true;
  std::vector<double> solver_tolerances;  ///< empty: defaultSweepTolerances()
  std::vector<int> solver_caps;           ///< empty: defaultSweepCaps()
  std::optional<double> reference_solver_tolerance;  ///< empty: kReferenceSolverTolerance
  bool help = false;
};

// ---- scenes --------------------------------------------------------------------------------------------------------

/// The same cloth at rows x cols: size, mass and spring constants kept (a square cell's sheet stiffness per unit
/// width is its spring's stiffness, whatever the cell size), air damping per particle and the paper wind per
/// triangle scaled so that the cloth as a whole feels the same.
void resampleScene(const GridSize& grid, core::SceneOptions* scene);

/// The scene file, the overrides, --dynamic, then `grid` (resampled), validated once.
bool buildToolScene(const ToolOptions& options, const std::optional<GridSize>& grid, core::SceneOptions* scene,
                    std::vector<std::string>* errors);

// ---- text ----------------------------------------------------------------------------------------------------------

std::string gridText(int rows, int cols);
std::string substepsText(const core::SceneOptions& scene);
/// "ok" or "DIVERGED <why>", with the guard's rollbacks and recomputations when there were any.
std::string stabilityText(bool stable, const SpanRun& run);
/// `digits` significant digits; "nan", "inf", "-inf" spelt out.
std::string formatNumber(double value, int digits = 3);
/// A CSV field, quoted where it holds a comma, quote or newline.
std::string csvField(const std::string& text);

/// A percentage on stderr: rewritten in place on a terminal, one line per ten percent in a log.
class Progress {
 public:
  explicit Progress(std::string what);
  void show(long long percent, const std::string& doing);

 private:
  std::string what_;
  bool terminal_;
  long long next_logged_ = 0;
};

// ---- the rk4 reference ---------------------------------------------------------------------------------------------

/// rk4 at doubling substeps (guard retries off) until the final positions converge (convergeReference).
Reference computeReference(const core::SceneOptions& scene, int frames, const ReferenceLimits& given,
                           const std::string& label);

/// The evidence that the reference converged, one line per run.
void printReference(std::ostream& out, const Reference& reference, double tolerance_m, const std::string& prefix);

// ---- output files --------------------------------------------------------------------------------------------------

/// Writes the CSV where asked, and the PNG through it (a temporary CSV next to the PNG when none was asked for).
bool writeOutputs(const ToolOptions& options, const std::string& plot_kind,
                  const std::function<bool(const std::string&)>& write_csv);

/// Writes `text` to options.csv_path when one was asked for; false (with a message) if it cannot.
bool writeCsvText(const ToolOptions& options, const std::string& text);

// ---- the modes -----------------------------------------------------------------------------------------------------

int runAccuracy(const ToolOptions& options, const core::SceneOptions& scene);
int runSpatial(const ToolOptions& options);
int runStabilityMap(const ToolOptions& options);
int runTerms(const ToolOptions& options, const core::SceneOptions& scene);
int runSolverSweep(const ToolOptions& options, const core::SceneOptions& scene);

}  // namespace cloth_sim::bench
