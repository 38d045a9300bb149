// Paper §6: the four explicit integrators, their orders, energy behaviour and determinism.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/simulation.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace cloth_sim::core {
namespace {

/// x'' = -(k/m) x - (c/m) x' for every coordinate of every particle (Drake's test system: k = 300 N/m, m = 2 kg).
class DampedOscillator final : public Dynamics {
 public:
  DampedOscillator(double stiffness_N_per_m, double damping_N_s_per_m, double mass_kg)
      : k_(stiffness_N_per_m), c_(damping_N_s_per_m), m_(mass_kg) {}
  void forces(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& v, double, Eigen::Matrix3Xd& f) override {
    f = -k_ * x - c_ * v;
    resizeMasses(x.cols());
  }
  const Eigen::VectorXd& mass_kg() const override { return mass_; }
  const Eigen::VectorXd& inverseMass_per_kg() const override { return inverse_mass_; }
  void constrainedPositions(double, Eigen::Matrix3Xd&) const override {}
  void linearize(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd&, double) override { resizeMasses(x.cols()); }
  void forceDifferential(const Eigen::Matrix3Xd& dx, const Eigen::Matrix3Xd& dv, Eigen::Matrix3Xd& df) override {
    df = -k_ * dx - c_ * dv;
  }
  void systemDiagonalBlocks(double h, Eigen::Matrix<double, 6, Eigen::Dynamic>& blocks) override {
    blocks.setZero(6, mass_.size());
    blocks.topRows<3>().setConstant(m_ + h * c_ + h * h * k_);
  }
  /// Closed form for x(0) = x0, v(0) = 0 (underdamped).
  double exactPosition(double x0, double t) const {
    const double w0 = std::sqrt(k_ / m_);
    const double zeta = c_ / (2.0 * std::sqrt(k_ * m_));
    const double wd = w0 * std::sqrt(1.0 - zeta * zeta);
    return x0 * std::exp(-zeta * w0 * t) * (std::cos(wd * t) + zeta * w0 / wd * std::sin(wd * t));
  }
  double energy(const ClothState& s) const {
    return 0.5 * m_ * s.velocities_m_per_s.squaredNorm() + 0.5 * k_ * s.positions_m.squaredNorm();
  }

 private:
  void resizeMasses(Eigen::Index count) {
    mass_.setConstant(count, m_);
    inverse_mass_.setConstant(count, 1.0 / m_);
  }
  double k_, c_, m_;
  Eigen::VectorXd mass_, inverse_mass_;
};

/// The implicit solver run to rounding: the order tests measure the method, not the solver's tolerance.
SolverOptions exactSolve() {
  SolverOptions solver;
  solver.tolerance = 1e-12;
  solver.max_iterations = 1000;
  return solver;
}

ClothState oneParticleAt(double x0) {
  ClothState s;
  s.positions_m = Eigen::Matrix3Xd::Zero(3, 1);
  s.positions_m(0, 0) = x0;
  s.velocities_m_per_s = Eigen::Matrix3Xd::Zero(3, 1);
  return s;
}

/// Largest |x - x_exact| over the samples t = 0.05 s, 0.1 s, ... up to 1 s, stepping with h = 0.05 / n.
double oscillatorError(IntegratorKind kind, int steps_per_sample) {
  DampedOscillator system(300.0, 2.0, 2.0);
  const double x0 = 0.1;
  const double sample_s = 0.05;
  std::unique_ptr<Integrator> integrator = makeIntegrator(kind, exactSolve());
  ClothState s = oneParticleAt(x0);
  double worst = 0.0;
  for (int sample = 1; sample <= 20; ++sample) {
    for (int k = 0; k < steps_per_sample; ++k) integrator->step(system, sample_s / steps_per_sample, s);
    worst = std::max(worst, std::abs(s.positions_m(0, 0) - system.exactPosition(x0, sample * sample_s)));
  }
  return worst;
}

/// A small soft cloth (6 x 6, two corners pinned, gravity, every spring damped) run for 0.2 s.
SceneOptions smallCloth(IntegratorKind kind, int substeps) {
  SceneOptions o;
  o.rows = 6;
  o.cols = 6;
  o.springs[0] = {true, 100.0, 0.05};
  o.springs[1] = {true, 20.0, 0.01};
  o.springs[2] = {true, 5.0, 0.005};
  o.integrator = kind;
  o.substeps = substeps;
  o.solver = exactSolve();
  return o;
}

Eigen::Matrix3Xd runSmallCloth(IntegratorKind kind, int substeps, int frames) {
  Simulation sim(smallCloth(kind, substeps));
  for (int f = 0; f < frames; ++f) sim.advanceFrame();
  return sim.state().positions_m;
}

/// Substeps per frame (or per oscillator sample) where each method is in its asymptotic range but its
/// error stays far above rounding: low order needs small steps, RK4 large ones.
int baseSteps(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kForwardEuler:
    case IntegratorKind::kSymplecticEuler:
    case IntegratorKind::kImplicitEuler:
      return 200;
    case IntegratorKind::kMidpoint:
      return 40;
    case IntegratorKind::kRK4:
      return 10;
  }
  return 0;
}

class IntegratorOrder : public ::testing::TestWithParam<IntegratorKind> {};

TEST_P(IntegratorOrder, DampedOscillatorErrorShrinksAtTheMethodsOrderWhenTheStepHalves) {
  const IntegratorKind kind = GetParam();
  const int order = makeIntegrator(kind)->order();
  const int n = baseSteps(kind);
  const double e1 = oscillatorError(kind, n);
  const double e2 = oscillatorError(kind, 2 * n);
  const double e4 = oscillatorError(kind, 4 * n);
  const double rate1 = std::log2(e1 / e2);
  const double rate2 = std::log2(e2 / e4);
  RecordProperty("observed_order", std::to_string(rate2));
  std::printf("[ oscillator ] %-16s errors %.3e %.3e %.3e observed orders %.3f %.3f (expected %d)\n",
              integratorName(kind), e1, e2, e4, rate1, rate2, order);
  EXPECT_NEAR(rate1, order, 0.2);
  EXPECT_NEAR(rate2, order, 0.2);
}

TEST_P(IntegratorOrder, SmallClothErrorAgainstAFineReferenceShrinksAtTheMethodsOrder) {
  const IntegratorKind kind = GetParam();
  const int order = makeIntegrator(kind)->order();
  const int frames = 10;  // 0.2 s
  // Substeps per 0.02 s frame; RK4 needs at least 5 (h = 4 ms, w_max h ~ 0.5) to be in its asymptotic range.
  const int n = std::max(baseSteps(kind) / 4, 5);
  // Reference: RK4 with 2000 substeps per frame (10 us), error ~1e-14 m, far below any tested error.
  const Eigen::Matrix3Xd reference = runSmallCloth(IntegratorKind::kRK4, 2000, frames);
  const double e1 = (runSmallCloth(kind, n, frames) - reference).cwiseAbs().maxCoeff();
  const double e2 = (runSmallCloth(kind, 2 * n, frames) - reference).cwiseAbs().maxCoeff();
  const double e4 = (runSmallCloth(kind, 4 * n, frames) - reference).cwiseAbs().maxCoeff();
  const double rate1 = std::log2(e1 / e2);
  const double rate2 = std::log2(e2 / e4);
  std::printf("[ cloth      ] %-16s errors %.3e %.3e %.3e observed orders %.3f %.3f (expected %d)\n",
              integratorName(kind), e1, e2, e4, rate1, rate2, order);
  EXPECT_NEAR(rate1, order, 0.2);
  EXPECT_NEAR(rate2, order, 0.2);
}

INSTANTIATE_TEST_SUITE_P(AllIntegrators, IntegratorOrder, ::testing::ValuesIn(allIntegratorKinds()),
                         [](const ::testing::TestParamInfo<IntegratorKind>& info) {
                           return std::string(integratorName(info.param));
                         });

TEST(Integrators, ForwardEulerOnAnUndampedSpringGainsExactlyOnePlusOmegaHSquaredPerStep) {
  // Forward Euler multiplies E = m v^2 / 2 + k x^2 / 2 by (1 + w^2 h^2) every step: bounded drift over a
  // fixed horizon (not conservation), and exactly this much.
  DampedOscillator spring(300.0, 0.0, 2.0);
  const double omega = std::sqrt(300.0 / 2.0);
  const double step_s = 1e-3;
  const int steps = 1000;  // 1 s
  ForwardEuler euler;
  ClothState s = oneParticleAt(0.1);
  const double e0 = spring.energy(s);
  for (int k = 0; k < steps; ++k) euler.step(spring, step_s, s);
  const double growth = spring.energy(s) / e0;
  const double predicted = std::pow(1.0 + omega * omega * step_s * step_s, steps);
  EXPECT_GT(growth, 1.1) << "forward Euler does not conserve energy";
  EXPECT_NEAR(growth, predicted, 1e-9 * predicted);
}

TEST(Integrators, EnergyDriftOnAnUndampedSpringRanksRK4BelowMidpointBelowSymplecticBelowForward) {
  DampedOscillator spring(300.0, 0.0, 2.0);
  const double step_s = 5e-3;  // w h = 0.06
  std::vector<double> drift;
  for (IntegratorKind kind : {IntegratorKind::kRK4, IntegratorKind::kMidpoint, IntegratorKind::kSymplecticEuler,
                              IntegratorKind::kForwardEuler}) {
    std::unique_ptr<Integrator> integrator = makeIntegrator(kind);
    ClothState s = oneParticleAt(0.1);
    const double e0 = spring.energy(s);
    double worst = 0.0;
    for (int k = 0; k < 2000; ++k) {  // 10 s, about 20 periods
      integrator->step(spring, step_s, s);
      worst = std::max(worst, std::abs(spring.energy(s) / e0 - 1.0));
    }
    std::printf("[ drift      ] %-16s max |E/E0 - 1| over 10 s: %.3e\n", integratorName(kind), worst);
    drift.push_back(worst);
  }
  EXPECT_LT(drift[0], drift[1]);
  EXPECT_LT(drift[1], drift[2]);
  EXPECT_LT(drift[2], drift[3]);
  EXPECT_LT(drift[2], 0.1) << "symplectic Euler's energy error stays bounded, of order w h";
}

/// Every coefficient of two states is the same double (NaN-safe, bit for bit).
void expectBitwiseEqual(const ClothState& a, const ClothState& b) {
  ASSERT_EQ(a.positions_m.cols(), b.positions_m.cols());
  EXPECT_EQ(a.time_s, b.time_s);
  EXPECT_EQ(a.frame, b.frame);
  EXPECT_EQ(0, std::memcmp(a.positions_m.data(), b.positions_m.data(), sizeof(double) * a.positions_m.size()));
  EXPECT_EQ(0, std::memcmp(a.velocities_m_per_s.data(), b.velocities_m_per_s.data(),
                           sizeof(double) * a.velocities_m_per_s.size()));
  for (Eigen::Index i = 0; i < a.positions_m.size(); ++i) {
    ASSERT_EQ(a.positions_m.data()[i], b.positions_m.data()[i]) << "coefficient " << i;
  }
}

/// The ball scene with wind and a grasp on top: every force kernel and the sphere contact in play.
SceneOptions busyScene() {
  SceneOptions o = test::loadBuiltinScene("ball");
  o.wind_enabled = true;
  o.wind.velocity_m_per_s = Eigen::Vector3d(1.0, 2.0, 0.0);
  o.wind.gust_amplitude = 0.5;
  return o;
}

TEST(Determinism, TwoSimulationsWithTheSameInputsGiveIdenticalBits) {
  Simulation a(busyScene());
  Simulation b(busyScene());
  GraspRequest grasp;
  grasp.id = 7;
  grasp.target_m = Eigen::Vector3d(0.3, 0.2, 0.6);
  std::string error;
  ASSERT_TRUE(a.grab(grasp, &error)) << error;
  ASSERT_TRUE(b.grab(grasp, &error)) << error;
  for (int frame = 0; frame < 150; ++frame) {
    a.advanceFrame();
    b.advanceFrame();
  }
  expectBitwiseEqual(a.state(), b.state());
}

TEST(Determinism, SaveRunRestoreRerunGivesIdenticalBits) {
  Simulation sim(busyScene());
  for (int frame = 0; frame < 40; ++frame) sim.advanceFrame();
  const ClothState saved = sim.state();
  for (int frame = 0; frame < 60; ++frame) sim.advanceFrame();
  const ClothState first = sim.state();
  std::string error;
  ASSERT_TRUE(sim.restoreState(saved, &error)) << error;
  for (int frame = 0; frame < 60; ++frame) sim.advanceFrame();
  expectBitwiseEqual(first, sim.state());
}

TEST(Damping, SpringDampingDoesNotDrainRigidTranslation) {
  // Spring damping acts on relative velocity only, so a rigidly translating cloth keeps its kinetic
  // energy exactly (air damping off: it is meant to act on absolute velocity).
  SceneOptions o = test::freeCloth(10, 10);
  o.air_damping_N_s_per_m = 0.0;
  for (SpringOptions& s : o.springs) s.damping_N_s_per_m = 1.0;  // heavy: 8x the default structural damping
  for (IntegratorKind kind : allIntegratorKinds()) {
    o.integrator = kind;
    Simulation sim(o);
    ClothState moving = sim.state();
    moving.velocities_m_per_s.colwise() = Eigen::Vector3d(1.0, -0.5, 0.25);
    std::string error;
    ASSERT_TRUE(sim.restoreState(moving, &error));
    const double e0 = sim.energies().kinetic_J;
    for (int frame = 0; frame < 100; ++frame) sim.advanceFrame();
    EXPECT_NEAR(sim.energies().kinetic_J, e0, 1e-12 * e0) << integratorName(kind);
  }
}

TEST(StabilityGuard, AFrameThatDivergesIsRecomputedWithMoreSubstepsNotFrozen) {
  // A stiff hand on a light corner particle: stable only with more substeps than the scene has.
  SceneOptions o = test::withSymplecticEuler(SceneOptions());
  o.substeps = 10;
  Simulation sim(o);
  GraspRequest hand;
  hand.particle = sim.grid().index(o.rows - 1, 0);
  hand.target_m = sim.state().positions_m.col(hand.particle) + Eigen::Vector3d(0.0, 0.3, 0.0);
  hand.stiffness_N_per_m = 2000.0;
  std::string error;
  ASSERT_TRUE(sim.grab(hand, &error)) << error;
  int recomputed = 0;
  for (int frame = 0; frame < 50; ++frame) {
    const FrameReport report = sim.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    ASSERT_TRUE(isFiniteAndBounded(sim.state(), Simulation::kDivergenceBound_m));
    if (report.substeps_used > o.substeps) {
      ++recomputed;
      EXPECT_NE(report.reason.find("recomputed"), std::string::npos) << report.reason;
    }
  }
  EXPECT_GT(recomputed, 0) << "the grasp was not stiff enough to need the guard: the test proves nothing";
  EXPECT_EQ(sim.state().frame, 50u) << "every frame advanced";
}

TEST(StabilityGuard, AHopelessFrameIsRolledBackAndTheStateStaysFinite) {
  // The stiffest springs the options accept, one substep: even 8 substeps cannot hold it. Instability
  // grows over a few frames; the first frame that still diverges with the guard must be rolled back.
  SceneOptions o = test::withSymplecticEuler(SceneOptions());
  o.substeps = 1;
  o.springs[static_cast<int>(SpringKind::kStructural)].stiffness_N_per_m = OptionLimits::kMaxStiffnessN_per_m;
  Simulation sim(o);
  constexpr int kFrames = 200;
  for (int frame = 0; frame < kFrames; ++frame) {
    const ClothState before = sim.state();
    const FrameReport report = sim.advanceFrame();
    ASSERT_TRUE(isFiniteAndBounded(sim.state(), Simulation::kDivergenceBound_m)) << "frame " << frame;
    if (report.stable) continue;
    EXPECT_EQ(report.substeps_used, o.substeps << Simulation::kGuardDoublings);
    EXPECT_NE(report.reason.find("rolled back"), std::string::npos) << report.reason;
    EXPECT_TRUE(sim.state().positions_m == before.positions_m) << "not rolled back";
    EXPECT_TRUE(sim.state().velocities_m_per_s == before.velocities_m_per_s) << "not rolled back";
    EXPECT_EQ(sim.state().frame, before.frame);
    return;
  }
  FAIL() << "no frame diverged in " << kFrames << " frames: the test proves nothing";
}

/// The stiffest cloth the options accept (structural 1e7 N/m), hanging from two corners.
SceneOptions stiffHangingCloth(IntegratorKind kind, int substeps) {
  SceneOptions o;
  o.springs[static_cast<int>(SpringKind::kStructural)].stiffness_N_per_m = OptionLimits::kMaxStiffnessN_per_m;
  o.integrator = kind;
  o.substeps = substeps;
  return o;
}

TEST(ImplicitEuler, AStiffClothAtOneStepPerFrameStaysFiniteAndUnstretchedWhereEveryExplicitMethodDiverges) {
  constexpr int kFrames = 50;
  Simulation implicit(stiffHangingCloth(IntegratorKind::kImplicitEuler, 1));
  int force_evaluations = 0;
  int steps = 0;
  for (int frame = 0; frame < kFrames; ++frame) {
    const FrameReport report = implicit.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    ASSERT_FALSE(report.recomputed) << report.reason;
    // A CG iteration costs about one force evaluation: count both.
    force_evaluations += report.steps.force_evaluations + report.steps.solver_iterations;
    steps += report.substeps_used;
  }
  EXPECT_TRUE(isFiniteAndBounded(implicit.state(), Simulation::kDivergenceBound_m));
  EXPECT_LT(implicit.maxStructuralStrain(), 0.01) << "a 1e7 N/m cloth barely stretches under 0.5 kg";
  // Each explicit method gets the same number of force evaluations per frame (at least one step).
  const int evaluations_per_frame = force_evaluations / kFrames;
  for (IntegratorKind kind : {IntegratorKind::kForwardEuler, IntegratorKind::kSymplecticEuler,
                              IntegratorKind::kMidpoint, IntegratorKind::kRK4}) {
    const int stages = makeIntegrator(kind)->order() == 4 ? 4 : makeIntegrator(kind)->order();
    Simulation sim(stiffHangingCloth(kind, std::max(1, evaluations_per_frame / stages)));
    bool diverged = false;
    for (int frame = 0; frame < kFrames && !diverged; ++frame) diverged = !sim.advanceFrame().stable;
    EXPECT_TRUE(diverged) << integratorName(kind) << " with " << sim.options().substeps
                          << " substeps per frame did not diverge: the comparison proves nothing";
  }
  std::printf("[ implicit   ] stiff cloth: %d steps, %.1f force evaluations + CG iterations per frame, strain %.2e\n",
              steps, static_cast<double>(force_evaluations) / kFrames, implicit.maxStructuralStrain());
}

TEST(ImplicitEuler, TheForcesAfterAStoppedSolveLessItsShortfallAreTheOnesItsStepApplied) {
  // Backward Euler's system is M dv = h F_lin(end) - r for the force linearised at the step's start and
  // taken to its end, F_lin(end) = F0 + dF/dx h v1 + dF/dv dv, and the solve's residual r. So F_lin(end)
  // less the shortfall r / h is M dv / h to rounding, and the forces read where the step ends, less it,
  // are the ones the step applied up to the springs' curvature over one step; as read they also hold the
  // residual (the part static friction's test must not take for the cloth's load). A stiff cloth (the
  // stiffest structural springs allowed) a few frames after it was let go, stepped once with a solve
  // stopped after a few iterations (measured: 2.0e-3 N off as read, 1.6e-5 N less the shortfall, against
  // forces of 2.4e-5 N the step applied).
  constexpr int kSettleFrames = 10;  // swinging into its hang: springs working, one step barely curving them
  constexpr int kStoppedIterations = 3;
  constexpr double kStep_s = 0.02;
  Simulation sim(stiffHangingCloth(IntegratorKind::kImplicitEuler, 1));
  for (int frame = 0; frame < kSettleFrames; ++frame) sim.advanceFrame();
  ClothForceModel& model = sim.forceModel();
  const ClothState start = sim.state();
  ClothState state = start;
  SolverOptions stopped;
  stopped.tolerance = 1e-13;  // never reached in kStoppedIterations
  stopped.max_iterations = kStoppedIterations;
  ImplicitEuler integrator(stopped);
  const StepReport report = integrator.step(model, kStep_s, state);
  ASSERT_FALSE(report.converged) << "the solve must stop short";
  const Eigen::Matrix3Xd dv = state.velocities_m_per_s - start.velocities_m_per_s;

  Eigen::Matrix3Xd linearised, differential;
  model.forces(start.positions_m, start.velocities_m_per_s, start.time_s, linearised);
  model.linearize(start.positions_m, start.velocities_m_per_s, start.time_s);
  model.forceDifferential(kStep_s * state.velocities_m_per_s, dv, differential);
  linearised += differential;
  integrator.subtractSolveShortfall(kStep_s, linearised);
  Eigen::Matrix3Xd read;
  model.forces(state.positions_m, state.velocities_m_per_s, state.time_s, read);
  Eigen::Matrix3Xd corrected = read;
  integrator.subtractSolveShortfall(kStep_s, corrected);

  double identity_error_N = 0.0;
  double error_read_N = 0.0;
  double error_corrected_N = 0.0;
  double applied_N = 0.0;
  double force_scale_N = 0.0;
  const Eigen::VectorXd& inverse_mass = model.inverseMass_per_kg();
  for (Eigen::Index i = 0; i < read.cols(); ++i) {
    if (inverse_mass[i] == 0.0) continue;  // a pin: moved by prescription, not by the forces
    const Eigen::Vector3d applied = dv.col(i) / (inverse_mass[i] * kStep_s);
    applied_N = std::max(applied_N, applied.cwiseAbs().maxCoeff());
    force_scale_N = std::max(force_scale_N, read.col(i).cwiseAbs().maxCoeff());
    identity_error_N = std::max(identity_error_N, (linearised.col(i) - applied).cwiseAbs().maxCoeff());
    error_read_N = std::max(error_read_N, (read.col(i) - applied).cwiseAbs().maxCoeff());
    error_corrected_N = std::max(error_corrected_N, (corrected.col(i) - applied).cwiseAbs().maxCoeff());
  }
  std::printf("[ shortfall  ] end forces off M dv / h (at most %.3e N) by %.3e N as read, %.3e N less the "
              "shortfall; linearised, less it: %.3e N\n", applied_N, error_read_N, error_corrected_N, identity_error_N);
  EXPECT_LT(identity_error_N, 1e-9 * force_scale_N) << "M dv = h F_lin(end) - r";
  EXPECT_GT(error_read_N, applied_N) << "the stopped solve must leave a residual to take off";
  EXPECT_LT(error_corrected_N, 0.05 * error_read_N);
  // An explicit method solves nothing: it leaves the forces as they are.
  Eigen::Matrix3Xd unchanged = read;
  makeIntegrator(IntegratorKind::kSymplecticEuler)->subtractSolveShortfall(kStep_s, unchanged);
  EXPECT_TRUE(unchanged == read);
}

TEST(ImplicitEuler, EnergyDecaysAndNeverGrowsWithoutForcing) {
  // A free cloth (no gravity, no air, no pins) stretched 20 % and let go: no external force does work, so
  // kinetic plus elastic energy may only fall, frame after frame, and must fall by much.
  SceneOptions o = test::freeCloth(16, 16);
  o.integrator = IntegratorKind::kImplicitEuler;
  o.substeps = 1;
  o.air_damping_N_s_per_m = 0.0;
  for (SpringOptions& spring : o.springs) spring.damping_N_s_per_m = 0.0;  // only the method's own damping
  Simulation sim(o);
  ClothState stretched = sim.state();
  const Eigen::Vector3d centre = stretched.positions_m.rowwise().mean();
  stretched.positions_m = (1.2 * (stretched.positions_m.colwise() - centre)).colwise() + centre;
  std::string error;
  ASSERT_TRUE(sim.restoreState(stretched, &error)) << error;
  const auto total = [&sim] { return sim.energies().kinetic_J + sim.energies().potential_J; };
  const double e0 = total();
  double previous = e0;
  for (int frame = 0; frame < 100; ++frame) {
    sim.advanceFrame();
    const double e = total();
    EXPECT_LE(e, previous + 1e-12 * e0) << "frame " << frame;  // grows by no more than rounding
    previous = e;
  }
  EXPECT_LT(previous, 0.5 * e0) << "implicit Euler damps the oscillation";
}

TEST(ImplicitEuler, APinnedCornerLandsExactlyOnItsMovingHookAndTheSolverReportsItsWork) {
  SceneOptions o;
  o.pin_motion_amplitude_m = Eigen::Vector3d(0.2, 0.0, 0.0);
  o.pin_motion_period_s = 1.0;
  Simulation sim(o);
  const int corner = sim.pinnedParticles().front();
  for (int frame = 0; frame < 30; ++frame) {
    const FrameReport report = sim.advanceFrame();
    EXPECT_GT(report.steps.solver_iterations, 0);
    EXPECT_GE(report.steps.force_evaluations, 1);
  }
  const Eigen::Vector3d hook = sim.grid().rest_positions_m.col(corner) +
                               o.pin_motion_amplitude_m * std::sin(kTwoPi * sim.state().time_s / o.pin_motion_period_s);
  EXPECT_LT((sim.state().positions_m.col(corner) - hook).norm(), 1e-12);
}

}  // namespace
}  // namespace cloth_sim::core
