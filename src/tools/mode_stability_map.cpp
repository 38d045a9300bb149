// cloth_bench --stability-map: the largest stable step of each integrator on a free cloth at rest, against
// stiffness and mass, measured beside the single-mode theory (accuracy.h) for the grid's highest mode.
#include "accuracy_modes.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/force_model.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/state.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>

namespace cloth_sim::bench {

namespace {

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
  const double period_s = core::kTwoPi / omega;
  const int steps = std::clamp(static_cast<int>(std::ceil(kStabilityPeriods * period_s / step_s)), kMinStabilitySteps,
                               kMaxStabilitySteps);
  for (int k = 0; k < steps; ++k) {
    integrator->step(sim.forceModel(), step_s, state);
    if (!state.positions_m.allFinite() || !state.velocities_m_per_s.allFinite()) return false;
    if (rmsDistance(state.positions_m, rest) > kStabilityGrowthLimit * initial_m) return false;
  }
  return true;
}

}  // namespace

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

}  // namespace cloth_sim::bench
