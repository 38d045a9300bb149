// cloth_bench --spatial: each grid of the same cloth (same material, resampled) against the finest, at the
// particles they share, each with its own converged rk4 reference (the spatial error, apart from the time step's).
#include "accuracy_modes.h"

#include <iomanip>
#include <iostream>
#include <sstream>

namespace cloth_sim::bench {

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
  std::ostringstream file;
  file << "# scene: " << options.scene << "\n# seconds: " << options.seconds << "\n# frames: " << frames << "\n"
       << csv.str();
  if (!writeCsvText(options, file.str())) return kExitRunFailed;
  return kExitOk;
}

}  // namespace cloth_sim::bench
