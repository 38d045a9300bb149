// Every built-in scene loads, runs 10 s of simulated time and ends finite and plausible; scene files
// that are wrong are rejected with a message naming the field.
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

namespace cloth_sim::core {
namespace {

using test::columnOf;
using test::loadBuiltinScene;
using test::meanOf;
using test::rowOf;

constexpr int kTenSecondsOfFrames = 500;  // at 50 Hz
/// The most particles a built-in scene has at its own size (32 x 32: `pile`).
constexpr int kMostDefaultParticles = 32 * 32;

/// What a 10 s run saw, frame by frame.
struct SceneRun {
  std::vector<Eigen::Matrix3Xd> positions;  ///< after each frame
  std::vector<double> times_s;
  double worst_penetration_m = 0.0;
  double max_strain = 0.0;
  int unstable_frames = 0;
};

/// Runs the scene with sleep off: the "comes to rest" checks below measure the physics, not a sleeping cloth.
SceneRun runScene(const SceneOptions& given, int frames) {
  SceneOptions o = given;
  o.sleep_speed_m_per_s = 0.0;
  Simulation sim(o);
  SceneRun run;
  for (int frame = 0; frame < frames; ++frame) {
    const FrameReport report = sim.advanceFrame();
    if (!report.stable) ++run.unstable_frames;
    run.max_strain = std::max(run.max_strain, report.max_strain);
    run.worst_penetration_m = std::max(
        run.worst_penetration_m, maxPenetration(o.colliders, sim.state().time_s, sim.state().positions_m));
    run.positions.push_back(sim.state().positions_m);
    run.times_s.push_back(sim.state().time_s);
  }
  return run;
}

class EveryScene : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryScene, RunsTenSecondsStableFiniteAndWithNothingInsideAColllider) {
  const SceneOptions o = loadBuiltinScene(GetParam());
  ASSERT_EQ(o.name, GetParam());
  // A built-in scene stays small enough to show beside rviz on two cores; `pile` is the largest (a
  // crumple onto the ball needs 32 per side).
  EXPECT_LE(o.rows * o.cols, kMostDefaultParticles) << "a built-in scene larger than pile's 32 x 32";
  EXPECT_EQ(o.integrator, IntegratorKind::kImplicitEuler);
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  EXPECT_EQ(run.unstable_frames, 0);
  EXPECT_TRUE(run.positions.back().allFinite());
  EXPECT_LT(run.positions.back().cwiseAbs().maxCoeff(), 10.0) << "stays in the room";
  EXPECT_LE(run.worst_penetration_m, o.contact.depth_m);
  EXPECT_LT(run.max_strain, Simulation::kStrainWarning) << "never over-stretched";
  std::printf("[ scene      ] %-10s max strain %.3f, deepest %.2e m\n", o.name.c_str(), run.max_strain,
              run.worst_penetration_m);
}

INSTANTIATE_TEST_SUITE_P(BuiltinScenes, EveryScene,
                         ::testing::ValuesIn(builtinSceneNames(test::scenesDir())),  // every one, as listed
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST_P(EveryScene, At128x128ItsOwnDefaultsRunASecondWithNoFrameRolledBackAndAutoLearnsWithinAFewFrames) {
  // What froze every scene before implicit Euler: at 128 x 128 the explicit step limit is near 1e-5 s.
  // With `auto` a frame the guard rejects (the flag's per-triangle wind pushes 128 x 128 hard in its
  // first frame) is recomputed and remembered, so only the first few frames pay for it.
  constexpr int kLearningFrames = 3;
  SceneOptions o = loadBuiltinScene(GetParam());
  ASSERT_TRUE(o.autoSubsteps()) << "every built-in scene runs with substeps: auto";
  o.rows = 128;
  o.cols = 128;
  Simulation sim(o);
  constexpr int kOneSecondOfFrames = 50;
  int recomputed = 0;
  for (int frame = 0; frame < kOneSecondOfFrames; ++frame) {
    const FrameReport report = sim.advanceFrame();
    ASSERT_TRUE(report.stable) << o.name << " frame " << frame << ": " << report.reason;
    ASSERT_TRUE(report.recovery.empty()) << o.name << " frame " << frame << ": " << report.reason;
    if (report.recomputed) ++recomputed;
  }
  EXPECT_LE(recomputed, kLearningFrames) << o.name;
  EXPECT_EQ(sim.state().frame, static_cast<std::uint64_t>(kOneSecondOfFrames));
  EXPECT_TRUE(isFiniteAndBounded(sim.state(), Simulation::kDivergenceBound_m));
}

TEST(Scenes, TheBuiltinSceneListIsTheTenScenes) {
  EXPECT_EQ(builtinSceneNames(test::scenesDir()),
            (std::vector<std::string>{"ball", "curtain", "drape", "drop", "flag", "fold", "hanging", "pile", "robot",
                                      "tablecloth"}));
}

TEST(Scenes, HangingFileIsTheDefaults) {
  const SceneOptions file = loadBuiltinScene("hanging");
  const SceneOptions defaults;
  EXPECT_EQ(file.rows, defaults.rows);
  EXPECT_EQ(file.cols, defaults.cols);
  EXPECT_EQ(file.width_m, 1.0);
  EXPECT_EQ(file.height_m, 1.0);
  EXPECT_EQ(file.mass_kg, 0.5);
  EXPECT_EQ(file.origin_m, defaults.origin_m);
  EXPECT_EQ(file.u_axis, defaults.u_axis);
  EXPECT_EQ(file.v_axis, defaults.v_axis);
  EXPECT_EQ(file.gravity_m_per_s2, Eigen::Vector3d(0, 0, -9.81));
  EXPECT_EQ(file.pins, (std::vector<std::string>{"top_left", "top_right"}));
  EXPECT_EQ(file.pins, defaults.pins);
  EXPECT_EQ(file.wind_enabled, defaults.wind_enabled);
  EXPECT_TRUE(file.colliders.empty());
  EXPECT_EQ(file.substeps, defaults.substeps);
  for (int k = 0; k < kSpringKindCount; ++k) {
    EXPECT_EQ(file.springs[k].enabled, defaults.springs[k].enabled);
    EXPECT_EQ(file.springs[k].stiffness_N_per_m, defaults.springs[k].stiffness_N_per_m);
  }
  // Flat and vertical: the rest grid lies in the plane y = 0, spanning z from 1.5 m down to 0.5 m.
  Simulation sim(file);
  EXPECT_EQ(sim.grid().rest_positions_m.row(1).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_DOUBLE_EQ(sim.grid().rest_positions_m.row(2).maxCoeff() - sim.grid().rest_positions_m.row(2).minCoeff(), 1.0);
}

TEST(Scenes, HangingSettlesBelowItsTwoPins) {
  const SceneOptions o = loadBuiltinScene("hanging");
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  Simulation sim(o);
  const Eigen::Matrix3Xd& end = run.positions.back();
  const Eigen::Matrix3Xd& rest = sim.grid().rest_positions_m;
  // Still in its plane, hanging: the bottom edge 0.95-1.05 m below the pins, the top edge sagging a little.
  EXPECT_LT(end.row(1).cwiseAbs().maxCoeff(), 1e-9);
  const double drop_m = rest(2, 0) - meanOf(end, rowOf(sim.grid(), o.rows - 1)).z();
  EXPECT_GT(drop_m, 0.95);
  EXPECT_LT(drop_m, 1.05);
}

TEST(Scenes, FlagStreamsDownwind) {
  const SceneOptions o = loadBuiltinScene("flag");
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  Simulation sim(o);
  // Over the last 5 s the free edge (last column) stays well downwind (+y) of the pole at y = 0, on
  // average more than half the flag's length.
  double sum_y = 0.0;
  int samples = 0;
  for (std::size_t f = run.positions.size() / 2; f < run.positions.size(); ++f) {
    sum_y += meanOf(run.positions[f], columnOf(sim.grid(), o.cols - 1)).y();
    ++samples;
  }
  const double mean_y = sum_y / samples;
  std::printf("[ scene      ] flag: free edge on average %.2f m downwind of the pole (length %.2f m)\n", mean_y,
              o.width_m);
  EXPECT_GT(mean_y, 0.5 * o.width_m);
}

TEST(Scenes, CurtainBillowsInTheGustsAndFollowsItsRail) {
  const SceneOptions o = loadBuiltinScene("curtain");
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  Simulation sim(o);
  const std::vector<int> bottom = rowOf(sim.grid(), o.rows - 1);
  double least_y = 1e9;
  double most_y = -1e9;
  for (const Eigen::Matrix3Xd& x : run.positions) {
    least_y = std::min(least_y, meanOf(x, bottom).y());
    most_y = std::max(most_y, meanOf(x, bottom).y());
  }
  std::printf("[ scene      ] curtain: bottom hem swings between y = %.2f and %.2f m\n", least_y, most_y);
  EXPECT_GT(most_y, 0.2) << "blown into the room";
  EXPECT_GT(most_y - least_y, 0.1) << "the gusts make it move";
  EXPECT_LT(most_y, 0.8 * o.height_m) << "billows, not blown flat";
}

TEST(Scenes, TableclothRestsOnTheTableAndHangsOverItsEdges) {
  const SceneOptions o = loadBuiltinScene("tablecloth");
  ASSERT_EQ(o.colliders.boxes.size(), 1u);
  const BoxCollider& table = o.colliders.boxes[0];
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  Simulation sim(o);
  const ClothGrid& g = sim.grid();
  const Eigen::Matrix3Xd& end = run.positions.back();
  const int middle = g.index(o.rows / 2, o.cols / 2);
  const Eigen::Vector3d centre = end.col(middle);
  EXPECT_NEAR(centre.z(), table.max_m.z(), o.contact.depth_m) << "the middle lies on the table top";
  EXPECT_LT((centre - g.rest_positions_m.col(middle)).head<2>().norm(), 0.01) << "and has not slid off";
  // The middle of each edge hangs down the table's side, outside it, below the top.
  for (int particle : {g.index(0, o.cols / 2), g.index(o.rows - 1, o.cols / 2), g.index(o.rows / 2, 0),
                       g.index(o.rows / 2, o.cols - 1)}) {
    const Eigen::Vector3d hem = end.col(particle);
    EXPECT_LT(hem.z(), table.max_m.z() - 0.2) << "hangs over the edge: " << hem.transpose();
    EXPECT_GT(signedDistance(table, hem), -o.contact.depth_m);
  }
  // At rest: the last second moves less than a millimetre.
  EXPECT_LT((run.positions.back() - run.positions[run.positions.size() - 50]).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(Scenes, BallPushesTheClothWhichSwingsBack) {
  const SceneOptions o = loadBuiltinScene("ball");
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  Simulation sim(o);
  const ClothGrid& g = sim.grid();
  std::vector<int> all(g.particleCount());
  for (int i = 0; i < g.particleCount(); ++i) all[i] = i;
  // The sphere reaches furthest at t = T/4 = 1.5 s and is back behind the cloth's plane by t = 3 s.
  double pushed_m = 0.0;
  double back_m = 1e9;
  for (std::size_t f = 0; f < run.positions.size(); ++f) {
    const double y = meanOf(run.positions[f], all).y();
    if (run.times_s[f] <= 2.0) pushed_m = std::max(pushed_m, y);
    if (run.times_s[f] >= 3.0 && run.times_s[f] <= 6.0) back_m = std::min(back_m, std::abs(y));
  }
  std::printf("[ scene      ] ball: cloth pushed %.3f m on average, back to within %.3f m\n", pushed_m, back_m);
  EXPECT_GT(pushed_m, 0.1);
  EXPECT_LT(back_m, 0.2 * pushed_m);
}

TEST(Scenes, DrapeSagsBetweenItsHooksIntoFoldsAndSettles) {
  const SceneOptions o = loadBuiltinScene("drape");
  ASSERT_EQ(o.pin_positions_m.size(), 2u);
  // Its corners reach the hooks at 4 s: 8 s more to settle.
  constexpr int kTwelveSecondsOfFrames = 600;
  const SceneRun run = runScene(o, kTwelveSecondsOfFrames);
  Simulation sim(o);
  const ClothGrid& g = sim.grid();
  const Eigen::Matrix3Xd& end = run.positions.back();
  // The corners hang on their hooks, 0.6 m apart, not where the flat cloth had them (1 m apart).
  EXPECT_LT((end.col(g.index(0, 0)) - o.pin_positions_m[0]).norm(), 1e-12);
  EXPECT_LT((end.col(g.index(0, o.cols - 1)) - o.pin_positions_m[1]).norm(), 1e-12);
  // The top edge sags between them, and the cloth leaves its starting plane (y = 0) in folds.
  const Eigen::Vector3d top_middle = end.col(g.index(0, o.cols / 2));
  EXPECT_LT(top_middle.z(), o.pin_positions_m[0].z() - 0.03) << "the top edge sags";
  EXPECT_GT(end.row(1).maxCoeff() - end.row(1).minCoeff(), 0.1) << "folds out of the plane";
  // And settles: the last second moves less than a millimetre.
  const Eigen::Matrix3Xd& second_before = run.positions[run.positions.size() - 1 - 50];
  EXPECT_LT((end - second_before).colwise().norm().maxCoeff(), 1e-3);
  std::printf("[ scene      ] drape: top middle %.3f m below the hooks, fold depth (y span) %.3f m\n",
              o.pin_positions_m[0].z() - top_middle.z(), end.row(1).maxCoeff() - end.row(1).minCoeff());
}

TEST(Scenes, DropLandsFlatOnTheFloor) {
  const SceneOptions o = loadBuiltinScene("drop");
  const SceneRun run = runScene(o, kTenSecondsOfFrames);
  const Eigen::Matrix3Xd& end = run.positions.back();
  EXPECT_LT(end.row(2).cwiseAbs().maxCoeff(), o.contact.depth_m) << "every particle on the floor";
  const double span_x = end.row(0).maxCoeff() - end.row(0).minCoeff();
  EXPECT_NEAR(span_x, o.width_m, 0.02) << "flat, not crumpled";
  // Resting at one implicit step per frame: no particle creeps or jitters by a millimetre in a second.
  const Eigen::Matrix3Xd& second_before = run.positions[run.positions.size() - 1 - 50];
  EXPECT_LT((end - second_before).colwise().norm().maxCoeff(), 1e-3);
}

TEST(Scenes, AVeryLongRunOfTheFlagNeverLeavesA1000MetreBox) {
  SceneOptions o = loadBuiltinScene("flag");
  Simulation sim(o);
  for (int frame = 0; frame < 6000; ++frame) {  // 2 minutes of gusts
    ASSERT_TRUE(sim.advanceFrame().stable) << "frame " << frame;
    ASSERT_TRUE(isFiniteAndBounded(sim.state(), 1000.0)) << "frame " << frame;
  }
}

// ---- scene-file errors --------------------------------------------------------------------------------

std::vector<std::string> loadErrors(const std::string& yaml) {
  const std::string path = ::testing::TempDir() + "cloth_sim_bad_scene.yaml";
  std::ofstream(path) << yaml;
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_FALSE(loadSceneFile(path, &options, &errors)) << yaml;
  return errors;
}

/// The first error mentions every word in `needles`.
void expectErrorNames(const std::string& yaml, const std::vector<std::string>& needles) {
  const std::vector<std::string> errors = loadErrors(yaml);
  ASSERT_FALSE(errors.empty()) << yaml;
  for (const std::string& needle : needles) {
    EXPECT_NE(errors.front().find(needle), std::string::npos) << "'" << errors.front() << "' lacks '" << needle << "'";
  }
}

TEST(SceneFile, PinPositionsMustMatchThePinnedParticles) {
  expectErrorNames("pins: [top_left, top_right]\npin_positions: [[0, 0, 1]]\n",
                   {"pin_positions", "1 positions for 2 pinned particles"});
}

TEST(SceneFile, UnknownKeyIsRejectedByName) { expectErrorNames("rows: 10\nstifness: 3\n", {"unknown key", "stifness"}); }

TEST(SceneFile, WrongTypeNamesTheFieldAndWhatWasExpected) {
  expectErrorNames("rows: ten\n", {"rows", "'ten'", "integer"});
  expectErrorNames("origin: [1, 2]\n", {"origin", "3 numbers"});
  expectErrorNames("solver_preconditioner: jacobi\n",
                   {"solver_preconditioner", "'jacobi'", "block_jacobi, multigrid"});
  expectErrorNames("shear_enabled: maybe\n", {"shear_enabled", "true or false"});
  expectErrorNames("integrator: leapfrog\n", {"integrator", "rk4"});
  expectErrorNames("planes:\n  - {normal: [0, 0, 1], offst: 0}\n", {"planes", "offst"});
}

TEST(SceneFile, OutOfRangeValueNamesTheFieldAndTheRange) {
  expectErrorNames("substeps: 0\n", {"substeps", "[1, 10000]"});
  expectErrorNames("restitution: 1.5\n", {"restitution", "[0, 1]"});
  expectErrorNames("rows: 1\n", {"rows"});
  expectErrorNames("spheres:\n  - {center: [0, 0, 0], radius: -1}\n", {"spheres[0].radius"});
  expectErrorNames("planes:\n  - {normal: [0, 0, 2], offset: 0}\n", {"planes[0].normal", "unit"});
  expectErrorNames("pins: [middle]\n", {"pins", "middle"});
}

TEST(SceneFile, AKeyThatIsNotANameIsAnErrorNotAnException) {
  expectErrorNames("? [a, b]\n: 1\n", {"keys must be names"});
  expectErrorNames("planes:\n  - {? [x] : 1}\n", {"planes", "keys are names"});
}

TEST(SceneFile, NotYamlOrNotAMapOrMissingIsRejected) {
  expectErrorNames("rows: [1, 2\n", {"not valid YAML"});
  expectErrorNames("- rows\n", {"expected a map"});
  SceneOptions options;
  std::vector<std::string> errors;
  EXPECT_FALSE(loadSceneFile("/nonexistent/scene.yaml", &options, &errors));
  ASSERT_FALSE(errors.empty());
  EXPECT_NE(errors.front().find("no such file"), std::string::npos);
}

}  // namespace
}  // namespace cloth_sim::core
