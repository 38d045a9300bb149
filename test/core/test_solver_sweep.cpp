// The measuring side of `cloth_bench --solver-sweep` (src/tools/solver_sweep.h): implicit Euler's CG tolerance and
// iteration cap against a solve converged to 1e-9, on a small cloth released flat (where a truncated solve shows).
#include "bench_common.h"
#include "solver_sweep.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <vector>

namespace cloth_sim::bench {
namespace {

namespace core = cloth_sim::core;

constexpr int kFrames = 10;
/// No repeated timing runs: the tests check what was measured, never how fast.
constexpr double kNoMinTiming_s = 0.0;
constexpr int kOneTimingRun = 1;

/// An 8x8 hanging cloth released flat from its two top corners, implicit Euler with block-Jacobi CG: the
/// knob under test is the cap, and on 8x8 multigrid solves in one iteration (its coarsest level is direct),
/// where no cap or tolerance would show.
core::SceneOptions smallReleasedCloth() {
  core::SceneOptions options = core::test::loadBuiltinScene("hanging");
  options.rows = 8;
  options.cols = 8;
  makeDynamic(&options);
  options.integrator = core::IntegratorKind::kImplicitEuler;
  options.solver.preconditioner = core::PreconditionerKind::kBlockJacobi;
  EXPECT_TRUE(core::validateSceneOptions(options).empty());
  return options;
}

TEST(SolverSweep, TheReferenceSettingAgainstItselfHasNoErrorAndConvergesEveryFrame) {
  const core::SceneOptions scene = smallReleasedCloth();
  const SpanRun reference = solverReference(scene, kFrames);
  ASSERT_FALSE(reference.diverged) << reference.stopped;
  ASSERT_EQ(reference.trajectory.size(), static_cast<std::size_t>(kFrames));
  const SolverMeasurement m =
      measureSolverSetting(scene, SolverSetting{kReferenceSolverTolerance, kUncappedSolverIterations}, kFrames,
                           reference.trajectory, kNoMinTiming_s, kOneTimingRun);
  EXPECT_TRUE(m.stable) << m.run.stopped;
  EXPECT_EQ(m.error.frames, kFrames);
  EXPECT_EQ(m.error.max_m, 0.0);  // the same solve, deterministic: bit for bit
  EXPECT_EQ(m.final_max_error_m, 0.0);
  EXPECT_EQ(m.converged_share, 1.0);
  EXPECT_GT(m.iterations_per_step, 1.0);
  EXPECT_EQ(m.mean_substeps, 1.0);
  // The cloth really moved, so that a zero error says something.
  EXPECT_GT((reference.trajectory.back() - reference.trajectory.front()).cwiseAbs().maxCoeff(), 0.05);
}

TEST(SolverSweep, ATighterToleranceGivesASmallerErrorAndTakesMoreIterations) {
  const core::SceneOptions scene = smallReleasedCloth();
  const SpanRun reference = solverReference(scene, kFrames);
  ASSERT_FALSE(reference.diverged) << reference.stopped;
  std::vector<SolverMeasurement> sweep;
  for (double tolerance : {1e-1, 1e-2, 1e-4, 1e-6}) {
    sweep.push_back(measureSolverSetting(scene, SolverSetting{tolerance, kUncappedSolverIterations}, kFrames,
                                         reference.trajectory, kNoMinTiming_s, kOneTimingRun));
  }
  EXPECT_GT(sweep.back().error.max_m, 0.0) << "1e-6 is not the reference's 1e-9";
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    EXPECT_TRUE(sweep[i].stable) << sweep[i].run.stopped;
    EXPECT_EQ(sweep[i].converged_share, 1.0) << "tolerance " << sweep[i].setting.tolerance << " without a cap";
    if (i == 0) continue;
    EXPECT_LT(sweep[i].error.max_m, sweep[i - 1].error.max_m) << "tolerance " << sweep[i].setting.tolerance;
    EXPECT_GT(sweep[i].iterations_per_step, sweep[i - 1].iterations_per_step)
        << "tolerance " << sweep[i].setting.tolerance;
  }
}

TEST(SolverSweep, AnUncappedSolveConvergesEveryFrameWhileATightCapStopsShortAndCostsAccuracy) {
  const core::SceneOptions scene = smallReleasedCloth();
  const SpanRun reference = solverReference(scene, kFrames);
  ASSERT_FALSE(reference.diverged) << reference.stopped;
  constexpr int kTightCap = 3;
  const SolverMeasurement uncapped = measureSolverSetting(scene, SolverSetting{1e-3, kUncappedSolverIterations},
                                                          kFrames, reference.trajectory, kNoMinTiming_s, kOneTimingRun);
  const SolverMeasurement capped = measureSolverSetting(scene, SolverSetting{1e-3, kTightCap}, kFrames,
                                                        reference.trajectory, kNoMinTiming_s, kOneTimingRun);
  EXPECT_EQ(uncapped.converged_share, 1.0);
  EXPECT_GT(uncapped.iterations_per_step, kTightCap) << "the cap must bind for this test to mean anything";
  EXPECT_LT(capped.converged_share, 1.0);
  EXPECT_LE(capped.iterations_per_step, kTightCap);
  EXPECT_GT(capped.error.max_m, uncapped.error.max_m);
}

TEST(SolverSweep, TheReferenceIsCheckedAgainstASolveAThousandTimesTighterThatTheParserAccepts) {
  EXPECT_DOUBLE_EQ(referenceCheckTolerance(kReferenceSolverTolerance), 1e-12);
  EXPECT_EQ(referenceCheckTolerance(1e-13), core::OptionLimits::kMinSolverTolerance);
  // On a smooth short run the check and the reference agree far below what any setting swept is off by.
  const core::SceneOptions scene = smallReleasedCloth();
  const SpanRun reference = solverReference(scene, kFrames);
  const SpanRun check = solverReference(scene, kFrames, referenceCheckTolerance(kReferenceSolverTolerance));
  const SolverMeasurement loose = measureSolverSetting(scene, SolverSetting{1e-2, kUncappedSolverIterations}, kFrames,
                                                       reference.trajectory, kNoMinTiming_s, kOneTimingRun);
  EXPECT_LT(compareTrajectories(check.trajectory, reference.trajectory).max_m, 1e-3 * loose.error.max_m);
}

TEST(SolverSweep, ASettingChangesOnlyTheIntegratorAndTheSolveOfTheScene) {
  core::SceneOptions scene = smallReleasedCloth();
  scene.integrator = core::IntegratorKind::kRK4;
  scene.substeps = 3;
  const core::SceneOptions set = withSolverSetting(scene, SolverSetting{1e-5, 42});
  EXPECT_EQ(set.integrator, core::IntegratorKind::kImplicitEuler);
  EXPECT_EQ(set.solver.tolerance, 1e-5);
  EXPECT_EQ(set.solver.max_iterations, 42);
  EXPECT_EQ(set.substeps, 3);
  EXPECT_EQ(set.pins, scene.pins);
  EXPECT_EQ(capText(42), "42");
  EXPECT_EQ(capText(kUncappedSolverIterations), "none");
}

}  // namespace
}  // namespace cloth_sim::bench
