#include "accuracy.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>

namespace cloth_sim::bench {

namespace {

/// A step is stable when its spectral radius exceeds 1 by no more than this (rounding of the matrix entries).
constexpr double kRadiusTolerance = 1e-12;
/// Bisection stops when the stable and unstable bounds are within this factor of each other.
constexpr double kBisectionRelativeWidth = 1e-3;
/// The theoretical scan covers h omega from this ...
constexpr double kTheoryMinStepOmega = 1e-6;
/// ... to this: far beyond any explicit method's limit, so a method stable there is called unconditionally stable.
constexpr double kTheoryMaxStepOmega = 1e3;
/// Scan factor of the theoretical scan: fine enough not to step over a narrow unstable band.
constexpr double kTheoryScanGrowth = 1.05;
/// Richardson's estimate needs the changes to shrink by at least this ratio per halving to be trusted.
constexpr double kMinConvergenceRatio = 1.05;

using Matrix2 = Eigen::Matrix2d;

double spectralRadius(const Matrix2& m) {
  const double half_trace = 0.5 * m.trace();
  const double determinant = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0);
  const std::complex<double> root = std::sqrt(std::complex<double>(half_trace * half_trace - determinant, 0.0));
  return std::max(std::abs(half_trace + root), std::abs(half_trace - root));
}

/// One step of each method on y = (x, v), y' = A y with A = [[0, 1], [-omega^2, -c]].
Matrix2 amplificationMatrix(core::IntegratorKind kind, double omega, double c, double h) {
  Matrix2 a;
  a << 0.0, 1.0, -omega * omega, -c;
  const Matrix2 identity = Matrix2::Identity();
  const Matrix2 ha = h * a;
  switch (kind) {
    case core::IntegratorKind::kForwardEuler:
      return identity + ha;
    case core::IntegratorKind::kSymplecticEuler: {
      // v1 = v + h a(x, v); x1 = x + h v1.
      Matrix2 m;
      m << 1.0 - h * h * omega * omega, h - h * h * c, -h * omega * omega, 1.0 - h * c;
      return m;
    }
    case core::IntegratorKind::kMidpoint:
      return identity + ha + 0.5 * ha * ha;
    case core::IntegratorKind::kRK4: {
      const Matrix2 ha2 = ha * ha;
      return identity + ha + ha2 / 2.0 + ha2 * ha / 6.0 + ha2 * ha2 / 24.0;
    }
    case core::IntegratorKind::kImplicitEuler: {
      // (1 + h c + h^2 omega^2) dv = h (-omega^2 x - c v - h omega^2 v); v1 = v + dv; x1 = x + h v1.
      const double denominator = 1.0 + h * c + h * h * omega * omega;
      const double dv_dx = -h * omega * omega / denominator;
      const double dv_dv = -h * (c + h * omega * omega) / denominator;
      Matrix2 m;
      m << 1.0 + h * dv_dx, h * (1.0 + dv_dv), dv_dx, 1.0 + dv_dv;
      return m;
    }
  }
  return identity;
}

}  // namespace

double rmsDistance(const Eigen::Matrix3Xd& a_m, const Eigen::Matrix3Xd& b_m) {
  if (a_m.cols() == 0) return 0.0;
  return std::sqrt((a_m - b_m).squaredNorm() / static_cast<double>(a_m.cols()));
}

TrajectoryError compareTrajectories(const Trajectory& run, const Trajectory& reference,
                                    const std::vector<int>& particle_map) {
  TrajectoryError error;
  const std::size_t frames = std::min(run.size(), reference.size());
  double sum_squares = 0.0;
  long long samples = 0;
  for (std::size_t f = 0; f < frames; ++f) {
    const Eigen::Matrix3Xd& x = run[f];
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      const Eigen::Index j = particle_map.empty() ? i : particle_map[static_cast<std::size_t>(i)];
      const double distance = (x.col(i) - reference[f].col(j)).norm();
      // A NaN must not hide behind max(): it makes the whole error NaN.
      error.max_m = std::isnan(distance) ? distance : std::max(error.max_m, distance);
      sum_squares += distance * distance;
      ++samples;
    }
  }
  error.frames = static_cast<int>(frames);
  error.rms_m = samples > 0 ? std::sqrt(sum_squares / static_cast<double>(samples)) : 0.0;
  return error;
}

std::vector<int> nestedParticleMap(int coarse_rows, int coarse_cols, int fine_rows, int fine_cols) {
  if (coarse_rows < 2 || coarse_cols < 2) return {};
  const int row_factor = (fine_rows - 1) / (coarse_rows - 1);
  const int col_factor = (fine_cols - 1) / (coarse_cols - 1);
  if (row_factor < 1 || col_factor < 1 || (coarse_rows - 1) * row_factor != fine_rows - 1 ||
      (coarse_cols - 1) * col_factor != fine_cols - 1) {
    return {};
  }
  std::vector<int> map;
  map.reserve(static_cast<std::size_t>(coarse_rows * coarse_cols));
  for (int r = 0; r < coarse_rows; ++r) {
    for (int c = 0; c < coarse_cols; ++c) map.push_back(r * row_factor * fine_cols + c * col_factor);
  }
  return map;
}

std::optional<double> observedOrder(double previous_change, double latest_change) {
  if (!(previous_change > 0.0) || !(latest_change > 0.0)) return std::nullopt;
  return std::log2(previous_change / latest_change);
}

Reference convergeReference(const std::function<RefinementRun(int substeps)>& run, const ReferenceLimits& limits) {
  Reference reference;
  Trajectory previous;
  std::vector<double> changes;  // final RMS changes of successive stable halvings
  double spent_s = 0.0, last_cpu_s = 0.0;
  reference.stopped_because = "reached the substep limit";
  for (int substeps = limits.first_substeps; substeps <= limits.max_substeps; substeps *= 2) {
    // Halving the step doubles the work: do not start a run expected to overrun the budget.
    if (!reference.steps.empty() && spent_s + 2.0 * last_cpu_s > limits.cpu_budget_s) {
      reference.stopped_because = "CPU budget spent";
      break;
    }
    RefinementRun result = run(substeps);
    spent_s += result.cpu_s;
    last_cpu_s = result.cpu_s;
    RefinementStep step;
    step.substeps = substeps;
    step.step_s = limits.frame_s / substeps;
    step.cpu_s = result.cpu_s;
    step.diverged = result.diverged || result.trajectory.empty();
    if (step.diverged) {
      reference.steps.push_back(step);
      previous.clear();
      changes.clear();
      continue;
    }
    if (!previous.empty() && previous.size() == result.trajectory.size()) {
      step.final_rms_change_m = rmsDistance(previous.back(), result.trajectory.back());
      double largest = 0.0;
      for (std::size_t f = 0; f < previous.size(); ++f) {
        largest = std::max(largest, rmsDistance(previous[f], result.trajectory[f]));
      }
      step.max_rms_change_m = largest;
      changes.push_back(*step.final_rms_change_m);
    }
    reference.steps.push_back(step);
    reference.trajectory = std::move(result.trajectory);
    reference.substeps = substeps;
    previous = reference.trajectory;
    if (step.final_rms_change_m && *step.final_rms_change_m < limits.tolerance_m &&
        static_cast<int>(changes.size()) >= limits.min_changes) {
      reference.converged = true;
      reference.stopped_because = "converged";
      break;
    }
  }
  // Stopped by the budget or the substep limit after a single halving that already changed less than the
  // tolerance: converged, only without a second halving to show the order.
  if (!reference.converged && !changes.empty() && changes.back() < limits.tolerance_m) {
    reference.converged = true;
    reference.stopped_because = "converged (one halving only: " + reference.stopped_because + ")";
  }
  // The changes of a converging sequence shrink geometrically by r per halving; what is left of the error after
  // the last one is then the rest of that series, latest / (r - 1). Without a trustworthy ratio, the latest change
  // itself is the estimate.
  if (!changes.empty()) {
    const double latest = changes.back();
    reference.estimated_error_m = latest;
    if (changes.size() >= 2) {
      const double ratio = changes[changes.size() - 2] / latest;
      if (ratio > kMinConvergenceRatio) reference.estimated_error_m = latest / (ratio - 1.0);
    }
  } else {
    reference.estimated_error_m = std::numeric_limits<double>::infinity();
  }
  return reference;
}

std::vector<bool> paretoFront(const std::vector<CostError>& points) {
  std::vector<bool> front(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].valid) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < points.size() && !dominated; ++j) {
      if (j == i || !points[j].valid) continue;
      const bool no_worse = points[j].cost <= points[i].cost && points[j].error <= points[i].error;
      const bool better = points[j].cost < points[i].cost || points[j].error < points[i].error;
      dominated = no_worse && better;
    }
    front[i] = !dominated;
  }
  return front;
}

std::optional<std::size_t> cheapestWithin(const std::vector<CostError>& points, double max_error) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const CostError& p = points[i];
    if (!p.valid || !(p.error <= max_error)) continue;
    if (!best || p.cost < points[*best].cost || (p.cost == points[*best].cost && p.error < points[*best].error)) {
      best = i;
    }
  }
  return best;
}

std::optional<std::size_t> mostAccurateWithin(const std::vector<CostError>& points, double max_cost) {
  std::optional<std::size_t> best;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const CostError& p = points[i];
    if (!p.valid || !(p.cost <= max_cost)) continue;
    if (!best || p.error < points[*best].error || (p.error == points[*best].error && p.cost < points[*best].cost)) {
      best = i;
    }
  }
  return best;
}

double amplificationRadius(core::IntegratorKind kind, double omega_rad_per_s, double damping_rate_per_s,
                           double step_s) {
  return spectralRadius(amplificationMatrix(kind, omega_rad_per_s, damping_rate_per_s, step_s));
}

double largestStableStep(const std::function<bool(double step_s)>& stable, double h_min_s, double h_max_s,
                         double growth) {
  if (!stable(h_min_s)) return 0.0;
  double stable_s = h_min_s;
  double unstable_s = 0.0;
  for (double h = h_min_s * growth; h <= h_max_s * (1.0 + kBisectionRelativeWidth); h *= growth) {
    if (!stable(h)) {
      unstable_s = h;
      break;
    }
    stable_s = h;
  }
  if (unstable_s == 0.0) {
    if (stable(h_max_s)) return h_max_s;
    unstable_s = h_max_s;
  }
  while (unstable_s > stable_s * (1.0 + kBisectionRelativeWidth)) {
    const double middle = std::sqrt(stable_s * unstable_s);
    (stable(middle) ? stable_s : unstable_s) = middle;
  }
  return stable_s;
}

double theoreticalStableStep(core::IntegratorKind kind, double omega_rad_per_s, double damping_rate_per_s) {
  // Undamped, forward Euler's radius is sqrt(1 + (h omega)^2) and midpoint's sqrt(1 + (h omega)^4 / 4): above 1 at
  // every h > 0, but by less than rounding at small h, so the closed form decides.
  const bool grows_at_every_step =
      kind == core::IntegratorKind::kForwardEuler || kind == core::IntegratorKind::kMidpoint;
  if (grows_at_every_step && damping_rate_per_s <= 0.0) return 0.0;
  const auto stable = [&](double h) {
    return amplificationRadius(kind, omega_rad_per_s, damping_rate_per_s, h) <= 1.0 + kRadiusTolerance;
  };
  return largestStableStep(stable, kTheoryMinStepOmega / omega_rad_per_s, theoreticalStepCap_s(omega_rad_per_s),
                           kTheoryScanGrowth);
}

double theoreticalStepCap_s(double omega_rad_per_s) { return kTheoryMaxStepOmega / omega_rad_per_s; }

}  // namespace cloth_sim::bench
