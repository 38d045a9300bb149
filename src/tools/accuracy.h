// The measuring side of `cloth_bench --accuracy` and `--stability-map`, as plain functions on trajectories and
// numbers (no clocks, no I/O), so that the tests can check them on cases with known answers.
#pragma once

#include "cloth_sim/core/integrators.h"

#include <Eigen/Core>

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace cloth_sim::bench {

/// Positions of every particle at the end of every frame (frame 1 first), world frame, m.
using Trajectory = std::vector<Eigen::Matrix3Xd>;

/// Position error of a run against a reference, over the frames both have.
struct TrajectoryError {
  double rms_m = 0.0;  ///< sqrt of the mean over compared frames and particles of |x - x_ref|^2
  double max_m = 0.0;  ///< largest |x - x_ref| of any particle in any compared frame
  int frames = 0;      ///< frames compared
};

/// Root-mean-square distance between two position sets of the same size, m.
double rmsDistance(const Eigen::Matrix3Xd& a_m, const Eigen::Matrix3Xd& b_m);

/// Compares `run` with `reference` frame by frame. particle_map empty: run particle i against reference particle i;
/// otherwise against reference particle particle_map[i] (a coarse grid against a finer grid of the same cloth).
/// Frames beyond the shorter trajectory are left out.
TrajectoryError compareTrajectories(const Trajectory& run, const Trajectory& reference,
                                    const std::vector<int>& particle_map = {});

/// For a coarse rows x cols grid and a finer one spanning the same cloth, the fine particle that sits where each
/// coarse particle sits: fine = (coarse - 1) * f + 1 per side for an integer f. Empty when the grids do not nest.
std::vector<int> nestedParticleMap(int coarse_rows, int coarse_cols, int fine_rows, int fine_cols);

/// One refinement of the reference: the run with `substeps` per frame against the previous (coarser) one.
struct RefinementStep {
  int substeps = 0;
  double step_s = 0.0;
  std::optional<double> final_rms_change_m;  ///< RMS change of the final positions; empty for the first run
  std::optional<double> max_rms_change_m;    ///< the largest per-frame RMS change over the span
  bool diverged = false;
  double cpu_s = 0.0;
};

/// What a refinement run gives back.
struct RefinementRun {
  Trajectory trajectory;
  bool diverged = false;
  double cpu_s = 0.0;
};

/// The converged reference and the evidence for it.
struct Reference {
  Trajectory trajectory;  ///< the finest stable run
  int substeps = 0;       ///< its substeps per frame
  std::vector<RefinementStep> steps;
  bool converged = false;       ///< the last halving changed the final positions by less than the tolerance
  double estimated_error_m = 0; ///< of the kept run: Richardson's estimate from the last changes (see .cpp)
  std::string stopped_because;  ///< why refinement ended
};

struct ReferenceLimits {
  double tolerance_m = 1e-9;     ///< converged when halving changes the final positions by less than this, RMS
  int first_substeps = 16;
  int max_substeps = 8192;       ///< the scene's substep limit (OptionLimits::kMaxSubsteps) caps it anyway
  double cpu_budget_s = 120.0;   ///< no refinement is started that would be expected to run past this
  double frame_s = 0.02;         ///< frame duration, s: step = frame_s / substeps
  /// Halvings whose change must be measured before convergence is declared: two show the observed order.
  int min_changes = 2;
};

/// Doubles the substeps from limits.first_substeps until the final positions change by less than the tolerance,
/// the substeps or the budget run out. run(substeps) simulates the whole span.
Reference convergeReference(const std::function<RefinementRun(int substeps)>& run, const ReferenceLimits& limits);

/// Observed order of convergence from two successive changes (coarser first): log2(previous / latest).
std::optional<double> observedOrder(double previous_change, double latest_change);

/// A setting on the cost/error plane.
struct CostError {
  double cost = 0.0;   ///< e.g. ms of CPU per simulated second
  double error = 0.0;  ///< e.g. max position error, m
  bool valid = true;   ///< false: diverged or not measured; never on the front
};

/// true for each valid point that no other valid point dominates (no more cost, no more error, less of one).
std::vector<bool> paretoFront(const std::vector<CostError>& points);

/// The cheapest valid point with error <= max_error; empty if none.
std::optional<std::size_t> cheapestWithin(const std::vector<CostError>& points, double max_error);
/// The most accurate valid point with cost <= max_cost (the cheaper of equals); empty if none.
std::optional<std::size_t> mostAccurateWithin(const std::vector<CostError>& points, double max_cost);

// ---- stability ------------------------------------------------------------------------------------------------------

/// Spectral radius of one step of `kind` on the single mode x'' = -omega^2 x - c x' (c: the mode's damping rate,
/// 1/s) at step h: the amplification matrix of each method's update written out for this 2x2 system.
double amplificationRadius(core::IntegratorKind kind, double omega_rad_per_s, double damping_rate_per_s,
                           double step_s);

/// The largest h such that every step in (0, h] is stable by `stable` (found on a geometric scan from h_min by
/// `growth`, then refined by bisection to a relative width of 1e-3). 0 when h_min itself is unstable; h_max when
/// every scanned step up to it is stable.
double largestStableStep(const std::function<bool(double step_s)>& stable, double h_min_s, double h_max_s,
                         double growth = 2.0);

/// Theory: the largest stable step of `kind` on that single mode (spectral radius <= 1 + 1e-12), scanned from
/// 1e-6 / omega to 1e3 / omega.
double theoreticalStableStep(core::IntegratorKind kind, double omega_rad_per_s, double damping_rate_per_s);
/// The largest step theoreticalStableStep tries: a method stable there is unconditionally stable in practice.
double theoreticalStepCap_s(double omega_rad_per_s);

}  // namespace cloth_sim::bench
