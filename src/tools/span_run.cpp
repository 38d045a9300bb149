#include "span_run.h"

#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/state.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cloth_sim::bench {

double cpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

int frameCount(const core::SceneOptions& scene, double seconds) {
  return std::max(1, static_cast<int>(std::lround(seconds * scene.frame_rate_hz)));
}

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
    run.solver_iterations_total += report.steps.solver_iterations;
    if (report.steps.converged) ++run.converged_frames;
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

}  // namespace cloth_sim::bench
