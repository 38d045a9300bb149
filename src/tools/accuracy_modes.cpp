#include "accuracy_modes.h"

#include "cloth_sim/io/scene_file.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

#ifndef CLOTH_SIM_SCRIPTS_DIR
#error "compile with -DCLOTH_SIM_SCRIPTS_DIR=\"/path/to/scripts\""
#endif

namespace cloth_sim::bench {

namespace {

/// Progress on a log (not a terminal) is written once per this many percent.
constexpr long long kLogStepPercent = 10;
/// Spaces after a progress line on a terminal: they clear the rest of a longer previous line.
constexpr std::size_t kProgressPadding = 12;

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

}  // namespace

// ---- scenes --------------------------------------------------------------------------------------------------------

// Bend springs act across two cells and do not scale this simply: they are kept, a small difference next to the
// structural springs.
// A material scene needs nothing of this: its constants are per area already (core::resolveMaterial).
void resampleScene(const GridSize& grid, core::SceneOptions* scene) {
  if (scene->has_material) {
    scene->rows = grid.rows;
    scene->cols = grid.cols;
    return;
  }
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
  if (!loadSceneWithOverrides(options.scene, options.scenes_dir, options.overrides, scene, errors)) return false;
  if (options.dynamic) makeDynamic(scene);
  if (grid) resampleScene(*grid, scene);
  const std::string dynamic_problem = options.dynamic ? dynamicPinsProblem(*scene) : "";
  if (!dynamic_problem.empty()) {
    errors->push_back(dynamic_problem);
    return false;
  }
  return validateInto(*scene, errors);
}

// ---- text ----------------------------------------------------------------------------------------------------------

std::string gridText(int rows, int cols) { return std::to_string(rows) + "x" + std::to_string(cols); }

std::string substepsText(const core::SceneOptions& scene) {
  return scene.autoSubsteps() ? std::string(core::kAutoSubstepsName) : std::to_string(scene.substeps);
}

std::string stabilityText(bool stable, const SpanRun& run) {
  std::ostringstream out;
  out << (stable ? "ok" : "DIVERGED " + run.stopped);
  if (run.rolled_back > 0 || run.recomputed > 0) {
    out << " (rolled back " << run.rolled_back << ", recomputed " << run.recomputed << ")";
  }
  return out.str();
}

std::string formatNumber(double value, int digits) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::ostringstream out;
  out << std::setprecision(digits) << value;
  return out.str();
}

std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

Progress::Progress(std::string what) : what_(std::move(what)), terminal_(isatty(STDERR_FILENO) != 0) {}

void Progress::show(long long percent, const std::string& doing) {
  if (terminal_) {
    std::cerr << "\rcloth_bench: " << what_ << " " << std::setw(3) << percent << "% (" << doing << ")"
              << std::string(kProgressPadding, ' ') << (percent >= 100 ? "\n" : "") << std::flush;
  } else if (percent >= next_logged_) {
    std::cerr << "cloth_bench: " << what_ << " " << percent << "% (" << doing << ")\n";
    next_logged_ = (percent / kLogStepPercent + 1) * kLogStepPercent;
  }
}

// ---- the rk4 reference ---------------------------------------------------------------------------------------------

Reference computeReference(const core::SceneOptions& scene, int frames, const ReferenceLimits& given,
                           const std::string& label) {
  core::SceneOptions base = scene;
  base.integrator = core::IntegratorKind::kRK4;
  base.guard_retries = false;
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

// ---- output files --------------------------------------------------------------------------------------------------

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

bool writeCsvText(const ToolOptions& options, const std::string& text) {
  if (options.csv_path.empty()) return true;
  std::ofstream out(options.csv_path);
  out << text;
  if (!out) {
    std::cerr << "cloth_bench: cannot write " << options.csv_path << "\n";
    return false;
  }
  return true;
}

}  // namespace cloth_sim::bench
