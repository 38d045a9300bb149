// The command line of cloth_bench's measuring modes: one parser and one --help for all of them; each mode runs in
// its own file (accuracy_modes.h).
#include "accuracy_tool.h"

#include "accuracy.h"
#include "accuracy_modes.h"
#include "bench_common.h"
#include "solver_sweep.h"

#include "cloth_sim/core/options.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace cloth_sim::bench {

namespace {

/// Each measuring mode and the flag that asks for it: the one table the parser, the messages and
/// isAccuracyToolCommand read.
struct ModeFlag {
  const char* flag;
  Mode mode;
};
constexpr std::array<ModeFlag, 5> kModeFlags = {{{"--accuracy", Mode::kAccuracy},
                                                 {"--spatial", Mode::kSpatial},
                                                 {"--stability-map", Mode::kStabilityMap},
                                                 {"--terms", Mode::kTerms},
                                                 {"--solver-sweep", Mode::kSolverSweep}}};
/// The textile tests' mode (mode_validate.cpp), a clash beside any of these.
constexpr const char* kValidateFlag = "--validate";
/// In --caps: no cap (kUncappedSolverIterations).
constexpr const char* kNoCapName = "none";

constexpr const char* kUsage = R"(usage:
  cloth_bench --accuracy --scene NAME_OR_PATH --seconds T [--max-error E | --realtime] [--csv FILE] [--png FILE]
              [--grid RxC] [--set KEY=VALUE ...] [--integrators a,b] [--substeps-list 1,2,4]
              [--reference-budget S] [--reference-tolerance M] [--min-timing S] [--tolerances ...] [--caps ...]
              [--no-solver-sweep]
      Runs every integrator at 1..64 substeps per frame (and `auto`) for T simulated seconds and compares every
      frame with a converged reference (rk4, its step halved until the final positions change by less than
      --reference-tolerance, default 1e-9 m RMS; the evidence is printed). Reports cost (ms of CPU per simulated
      second), RMS and max position error, max strain and stability; marks the Pareto front (cost against max
      error); ends with a setting to paste: the cheapest with max error <= E (default 1e-3 m), or with
      --realtime the most accurate that runs at least at real time on this machine. Then, when implicit_euler
      is among the integrators, its solver's tolerance and cap as --solver-sweep measures them (--tolerances,
      --caps, --reference-solver-tolerance; printed only: --csv and --png hold the integrators' table), unless
      --no-solver-sweep.
  cloth_bench --spatial --scene NAME_OR_PATH --seconds T --grids 20x20,39x39,77x77 [--csv FILE] [--set ...]
      Each grid (same cloth, same material) against the finest, at the particles they share.
  cloth_bench --stability-map [--scene NAME_OR_PATH] [--grid 8x8] [--csv FILE] [--png FILE]
      Largest stable step of each integrator against stiffness and mass (free cloth, no gravity), undamped and
      with the scene's damping, beside the theory for the highest mode.
  cloth_bench --terms --scene NAME_OR_PATH --seconds T [--csv FILE]
      Cost per frame of the scene with each of its force and collider terms switched off, and how much that
      changes the cloth.
  cloth_bench --solver-sweep --scene NAME_OR_PATH --seconds T [--dynamic] [--grid RxC] [--set KEY=VALUE ...]
              [--tolerances 1e-1,3e-2,1e-2,1e-3,1e-4,1e-6] [--caps 10,25,50,100,200,none]
              [--reference-solver-tolerance 1e-9] [--max-error E] [--csv FILE]
      Implicit Euler's linear solve: each CG tolerance without a cap, and each iteration cap at the scene's
      tolerance (solver_tolerance, 1e-3 by default), against the same scene solved to 1e-9 without a cap. Per
      setting: CPU ms per frame, CG iterations per step, the share of frames whose every solve converged, the
      largest position error over every frame and at the last, max strain and the guard's work; then the
      cheapest setting with max error <= E (default 1e-3 m). The scene's own substeps and guard are kept;
      every --set applies to the reference and to each setting alike (e.g. --set solver_preconditioner=...).

  --scene NAME_OR_PATH   built-in scene name or a .yaml path (default hanging)
  --scenes-dir DIR       where built-in scenes live
  --dynamic              released flat: the cloth lies flat at the height of its top edge, its two top corners
                         pinned, and swings down (as plain cloth_bench --dynamic; applied after --set)
  --grid RxC             resample the scene to R x C particles, same cloth and material: spring constants kept
                         (a square cell's sheet stiffness does not depend on its size), mass shared out, air
                         damping per particle and the paper wind coefficient per triangle scaled by the counts
  --set KEY=VALUE        any scene key, as in a scene file (applied before --grid); repeatable
  --seconds T            simulated span (default 2; at most 1e4 s, and refused where one trajectory, every frame's
                         positions, would take over 1 GB: every mode but --stability-map keeps two or three)
  --reference-budget S   CPU seconds the reference may take (default 120)
  --min-timing S         time each setting over at least S CPU seconds of repeated runs (default 0.2; 0: once)
  --png FILE             plot with matplotlib (/usr/bin/python3 scripts/accuracy_plot.py)
)";

// ---- command line --------------------------------------------------------------------------------------------------

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

const char* modeFlag(Mode mode) {
  for (const ModeFlag& entry : kModeFlags) {
    if (entry.mode == mode) return entry.flag;
  }
  return kModeFlags.front().flag;
}

/// The entry whose flag this is, or null.
const ModeFlag* findModeFlag(const std::string& flag) {
  for (const ModeFlag& entry : kModeFlags) {
    if (flag == entry.flag) return &entry;
  }
  return nullptr;
}

/// The options a mode reads besides the scene's (--scene, --scenes-dir, --set, --dynamic), as its usage lists
/// them: any other is refused, not ignored (a --seconds given to --stability-map changed nothing).
const std::vector<std::string>& modeOptions(Mode mode) {
  static const std::vector<std::string> accuracy = {
      "--grid", "--seconds", "--max-error", "--realtime", "--csv", "--png", "--integrators", "--substeps-list",
      "--reference-budget", "--reference-tolerance", "--min-timing", "--tolerances", "--caps",
      "--reference-solver-tolerance", "--no-solver-sweep"};
  static const std::vector<std::string> spatial = {"--seconds", "--grids", "--csv", "--reference-budget",
                                                   "--reference-tolerance"};
  static const std::vector<std::string> stability_map = {"--grid", "--csv", "--png", "--integrators"};
  static const std::vector<std::string> terms = {"--grid", "--seconds", "--csv", "--min-timing"};
  static const std::vector<std::string> solver_sweep = {"--grid", "--seconds", "--tolerances", "--caps",
                                                        "--reference-solver-tolerance", "--max-error", "--csv",
                                                        "--min-timing"};
  switch (mode) {
    case Mode::kAccuracy: return accuracy;
    case Mode::kSpatial: return spatial;
    case Mode::kStabilityMap: return stability_map;
    case Mode::kTerms: return terms;
    case Mode::kSolverSweep: return solver_sweep;
  }
  return accuracy;
}

/// Whether a file can be written at `path` (its folder exists and is writable, and the file, if there, is
/// too): checked before a run that may take minutes, rather than after it.
bool writable(const std::string& path) {
  if (path.empty() || path.back() == '/') return false;  // a folder's name, not a file's
  struct stat status {};
  if (stat(path.c_str(), &status) == 0) return S_ISREG(status.st_mode) && access(path.c_str(), W_OK) == 0;
  const std::size_t slash = path.find_last_of('/');
  const std::string folder = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  return access(folder.c_str(), W_OK | X_OK) == 0;
}

/// What the flags given say together, checked once they are all read (not with --help).
void checkCombination(const ToolOptions& options, const std::vector<std::string>& modes_given,
                      const std::vector<std::string>& flags_given, std::vector<std::string>* errors) {
  if (modes_given.size() > 1) {
    std::string modes;
    for (const std::string& mode : modes_given) modes += (modes.empty() ? "" : " and ") + mode;
    errors->push_back(modes + ": one mode at a time");
    return;
  }
  const std::vector<std::string>& allowed = modeOptions(options.mode);
  const auto known = [](const std::string& flag) {  // an unknown option was refused as such already
    for (const ModeFlag& entry : kModeFlags) {
      const std::vector<std::string>& options_of = modeOptions(entry.mode);
      if (std::find(options_of.begin(), options_of.end(), flag) != options_of.end()) return true;
    }
    return false;
  };
  for (const std::string& flag : flags_given) {
    if (known(flag) && std::find(allowed.begin(), allowed.end(), flag) == allowed.end()) {
      errors->push_back(flag + ": not an option of " + modeFlag(options.mode) + " (see --help)");
    }
  }
  const auto given = [&](const char* flag) {
    return std::find(flags_given.begin(), flags_given.end(), flag) != flags_given.end();
  };
  if (options.mode == Mode::kAccuracy && given("--max-error") && given("--realtime")) {
    errors->push_back("--max-error and --realtime: the recommendation is one or the other");
  }
  const bool implicit = std::find(options.integrators.begin(), options.integrators.end(),
                                  core::IntegratorKind::kImplicitEuler) != options.integrators.end();
  if (options.mode == Mode::kAccuracy && (!options.solver_sweep || !implicit)) {
    for (const char* flag : {"--tolerances", "--caps", "--reference-solver-tolerance"}) {
      if (given(flag)) {
        errors->push_back(std::string(flag) + ": --accuracy runs no solver sweep here (" +
                          (options.solver_sweep ? "implicit_euler is not among --integrators" : "--no-solver-sweep") +
                          ")");
      }
    }
  }
  for (const auto& [flag, path] : {std::pair<const char*, std::string>{"--csv", options.csv_path},
                                   std::pair<const char*, std::string>{"--png", options.png_path}}) {
    if (given(flag) && (path.empty() || !writable(path))) {
      errors->push_back(std::string(flag) + " " + path + ": cannot write there");
    }
  }
  if (options.mode == Mode::kSpatial && options.grids.size() < 2) {
    errors->push_back("--spatial needs --grids with at least two grids, coarse first (e.g. 20x20,39x39,77x77)");
  } else if (options.mode == Mode::kSpatial) {
    const GridSize& finest = options.grids.back();
    for (std::size_t g = 0; g + 1 < options.grids.size(); ++g) {
      const GridSize& grid = options.grids[g];
      const GridSize& next = options.grids[g + 1];
      const std::string name = std::to_string(grid.rows) + "x" + std::to_string(grid.cols);
      if (!(grid.rows <= next.rows && grid.cols <= next.cols && (grid.rows < next.rows || grid.cols < next.cols))) {
        errors->push_back("--grids: " + name + " is not coarser than the grid after it (coarse first)");
      } else if (nestedParticleMap(grid.rows, grid.cols, finest.rows, finest.cols).empty()) {
        errors->push_back("--grids: " + name + " does not nest in the finest, " + std::to_string(finest.rows) + "x" +
                          std::to_string(finest.cols) + " (its rows - 1 and cols - 1 must divide the finest's)");
      }
    }
  }
}

void parseToolCommandLine(int argc, char** argv, ToolOptions* options, std::vector<std::string>* errors) {
  std::vector<std::string> modes_given;  // in the order given
  std::vector<std::string> flags_given;  // every other option, but the scene's
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      options->help = true;
      continue;
    }
    const ModeFlag* mode = findModeFlag(flag);
    if (mode != nullptr || flag == kValidateFlag) {
      // --validate is counted as a mode so that beside one of these it is a clash, not an unknown option.
      if (mode != nullptr) {
        options->mode = mode->mode;
      } else if (i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0) {
        ++i;  // its test's name
      }
      if (std::find(modes_given.begin(), modes_given.end(), flag) == modes_given.end()) modes_given.push_back(flag);
      continue;
    }
    if (flag != "--scene" && flag != "--scenes-dir" && flag != "--set" && flag != "--dynamic") {
      flags_given.push_back(flag);
    }
    if (flag == "--realtime") {
      options->realtime = true;
      continue;
    }
    if (flag == "--dynamic") {
      options->dynamic = true;
      continue;
    }
    if (flag == "--no-solver-sweep") {
      options->solver_sweep = false;
      continue;
    }
    if (i + 1 >= argc) {
      errors->push_back(flag + ": missing value or unknown option (see --help)");
      break;
    }
    const std::string value = argv[++i];
    // A list option given nothing but commas would silently keep its default (or run nothing).
    const auto some = [&](const std::vector<std::string>& items) {
      if (items.empty()) errors->push_back(flag + " " + value + ": an empty list");
      return items;
    };
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
      parseSceneSetting(value, &options->overrides, errors);
    } else if (flag == "--grid") {
      options->grid = parseGrid(value);
      if (!options->grid) errors->push_back("--grid " + value + ": expected ROWSxCOLS, each >= 2");
    } else if (flag == "--grids") {
      for (const std::string& item : some(splitList(value))) {
        const std::optional<GridSize> grid = parseGrid(item);
        if (!grid) {
          errors->push_back("--grids " + value + ": expected ROWSxCOLS,ROWSxCOLS,...");
          break;
        }
        options->grids.push_back(*grid);
      }
    } else if (flag == "--seconds") {
      const std::optional<double> number = parseDouble(value);
      if (!number || !(*number > 0.0) || *number > kMaxSpan_s) {
        errors->push_back(flag + " " + value + ": expected a number of seconds in (0, " +
                          std::to_string(static_cast<long>(kMaxSpan_s)) + "]");
      } else {
        options->seconds = *number;
      }
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
      for (const std::string& name : some(splitList(value))) {
        core::IntegratorKind kind;
        if (!core::parseIntegratorName(name, &kind)) {
          errors->push_back("--integrators: unknown '" + name + "' (known: " + core::integratorNameList() + ")");
        } else {
          options->integrators.push_back(kind);
        }
      }
    } else if (flag == "--substeps-list") {
      options->substep_counts.clear();
      for (const std::string& item : some(splitList(value))) {
        const std::optional<int> count = parseInt(item);
        if (!count || *count < 1 || *count > core::OptionLimits::kMaxSubsteps) {
          errors->push_back("--substeps-list: '" + item + "' is not a substep count in [1, 10000]");
        } else {
          options->substep_counts.push_back(*count);
        }
      }
    } else if (flag == "--tolerances") {
      for (const std::string& item : some(splitList(value))) {
        const std::optional<double> tolerance = parseDouble(item);
        if (!tolerance || *tolerance < core::OptionLimits::kMinSolverTolerance || *tolerance > 1.0) {
          errors->push_back("--tolerances: '" + item + "' is not a solver tolerance in [1e-14, 1]");
        } else {
          options->solver_tolerances.push_back(*tolerance);
        }
      }
    } else if (flag == "--caps") {
      for (const std::string& item : some(splitList(value))) {
        const std::optional<int> cap =
            item == kNoCapName ? std::optional<int>(kUncappedSolverIterations) : parseInt(item);
        if (!cap || *cap < 1 || *cap > kUncappedSolverIterations) {
          errors->push_back("--caps: '" + item + "' is not an iteration cap in [1, 10000] or '" + kNoCapName + "'");
        } else {
          options->solver_caps.push_back(*cap);
        }
      }
    } else if (flag == "--reference-solver-tolerance") {
      const std::optional<double> tolerance = parseDouble(value);
      if (!tolerance || *tolerance < core::OptionLimits::kMinSolverTolerance || *tolerance > 1.0) {
        errors->push_back(flag + " " + value + ": expected a solver tolerance in [1e-14, 1]");
      } else {
        options->reference_solver_tolerance = tolerance;
      }
    } else {
      errors->push_back("unknown option '" + flag + "' (see --help)");
    }
  }
  if (!options->help) checkCombination(*options, modes_given, flags_given, errors);
}

/// Every mode but the stability map keeps whole trajectories (a frame's positions for every frame, two or
/// three at once while a reference converges): a span too long for memory is refused before it runs. False
/// with the reason, naming the longest span that fits at this size.
bool trajectoryFits(const core::SceneOptions& scene, double seconds, std::string* error) {
  const double frame_bytes = static_cast<double>(scene.rows) * scene.cols * 3.0 * sizeof(double);
  const int frames = frameCount(scene, seconds);
  const double bytes = frames * frame_bytes;
  if (bytes <= kMaxTrajectoryBytes) return true;
  std::ostringstream out;
  out << "--seconds " << seconds << ": " << frames << " frames of " << scene.rows << "x"
      << scene.cols << " particles would keep " << bytes / kBytesPerGigabyte << " GB a trajectory (at most "
      << kMaxTrajectoryBytes / kBytesPerGigabyte << " GB: up to "
      << std::floor(kMaxTrajectoryBytes / frame_bytes / scene.frame_rate_hz) << " s at this size)";
  *error = out.str();
  return false;
}

}  // namespace

bool isAccuracyToolCommand(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (findModeFlag(argv[i]) != nullptr) return true;
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
    if (options.mode == Mode::kStabilityMap) return runStabilityMap(options);
    core::SceneOptions scene;  // for --spatial, the finest grid's (its trajectory is the largest)
    const std::optional<GridSize> grid = options.mode == Mode::kSpatial ? options.grids.back() : options.grid;
    std::string too_long;
    if (!buildToolScene(options, grid, &scene, &errors) || !trajectoryFits(scene, options.seconds, &too_long)) {
      if (!too_long.empty()) errors.push_back(too_long);
      for (const std::string& e : errors) std::cerr << "cloth_bench: " << e << "\n";
      return kExitUsage;
    }
    if (options.mode == Mode::kSpatial) return runSpatial(options);
    if (options.mode == Mode::kTerms) return runTerms(options, scene);
    if (options.mode == Mode::kSolverSweep) return runSolverSweep(options, scene);
    return runAccuracy(options, scene);
  } catch (const std::exception& e) {
    std::cerr << "cloth_bench: run failed: " << e.what() << "\n";
    return kExitRunFailed;
  }
}

}  // namespace cloth_sim::bench
