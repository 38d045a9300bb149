// A cloth at rest sleeps (SceneOptions::sleep_speed_m_per_s): it stops being computed once it has stood
// still for SceneOptions::kSleepAfter_s with nothing driving it, keeps its state bit for bit while asleep,
// and wakes on anything that would move it.
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/state_file.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

namespace cloth_sim::core {
namespace {

using test::loadBuiltinScene;

/// Frames the small sheet gets to come to rest on the floor (it lands in about 1 s).
constexpr int kMostFramesToSleep = 500;

/// The `drop` scene at 12 x 12: a sheet that falls flat onto the floor and lies there.
SceneOptions smallDrop() {
  SceneOptions options = loadBuiltinScene("drop");
  options.rows = 12;
  options.cols = 12;
  return options;
}

/// Advances until a frame is slept through; the number of frames computed before it, or -1.
int framesUntilAsleep(Simulation& simulation, int most = kMostFramesToSleep) {
  for (int frame = 0; frame < most; ++frame) {
    const FrameReport report = simulation.advanceFrame();
    EXPECT_TRUE(report.stable) << report.reason;
    if (report.asleep) return frame;
  }
  return -1;
}

TEST(Sleep, ASheetLyingOnTheFloorFallsAsleepAndKeepsItsStateBitForBit) {
  Simulation simulation(smallDrop());
  const int computed = framesUntilAsleep(simulation);
  ASSERT_GE(computed, simulation.options().sleepAfterFrames()) << "never slept, or slept before it was seen at rest";
  const ClothState asleep = simulation.state();
  const int substeps = simulation.lastFrameSubsteps();
  for (int frame = 1; frame <= 100; ++frame) {
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.asleep) << "frame " << frame << " woke with nothing to wake it";
    EXPECT_TRUE(report.stable);
    EXPECT_EQ(report.substeps_used, 0);
    EXPECT_EQ(report.steps.solver_iterations, 0);
  }
  EXPECT_TRUE(simulation.state().positions_m == asleep.positions_m);
  EXPECT_TRUE(simulation.state().velocities_m_per_s == asleep.velocities_m_per_s);
  EXPECT_EQ(simulation.state().frame, asleep.frame + 100);
  EXPECT_NEAR(simulation.state().time_s, asleep.time_s + 100 * simulation.options().frameDuration_s(), 1e-9);
  EXPECT_EQ(simulation.lastFrameSubsteps(), substeps) << "a sleeping cloth wakes with the substeps it had";
}

TEST(Sleep, WhatItSleepsThroughIsWhatTheComputedRunDoesToWithinTheSleepSpeed) {
  SceneOptions never = smallDrop();
  never.sleep_speed_m_per_s = 0.0;
  Simulation sleeping(smallDrop());
  Simulation computed(never);
  constexpr int kFrames = 400;  // 8 s: asleep for most of it
  int slept = 0;
  for (int frame = 0; frame < kFrames; ++frame) {
    slept += sleeping.advanceFrame().asleep ? 1 : 0;
    EXPECT_FALSE(computed.advanceFrame().asleep) << "sleep_speed 0 slept";
  }
  ASSERT_GT(slept, kFrames / 2);
  // Asleep it stands still; computed, the sheet moves less than sleep_speed (it was below it when it slept
  // and has nothing to speed it up).
  const double seconds_asleep = slept * never.frameDuration_s();
  const double apart_m =
      (sleeping.state().positions_m - computed.state().positions_m).colwise().norm().maxCoeff();
  EXPECT_LT(apart_m, smallDrop().sleep_speed_m_per_s * seconds_asleep);
  std::printf("[ sleep      ] drop 12x12: asleep %d of %d frames, %.3g m from the computed run\n", slept, kFrames,
              apart_m);
}

/// A hanging 10 x 10 cloth asleep on its two hooks.
std::unique_ptr<Simulation> sleepingHangingCloth(SceneOptions options = loadBuiltinScene("hanging")) {
  options.rows = 10;
  options.cols = 10;
  auto simulation = std::make_unique<Simulation>(options);
  EXPECT_GE(framesUntilAsleep(*simulation), 0) << "the hanging cloth never slept";
  return simulation;
}

/// One way of waking a sleeping cloth: applied between frames.
struct Waker {
  const char* name;
  void (*apply)(Simulation&);
};

TEST(Sleep, EveryInputWakesItBeforeTheNextFrame) {
  const std::vector<Waker> wakers{
      {"a grab", [](Simulation& s) {
         GraspRequest hand;
         hand.id = 1;
         hand.particle = 55;
         hand.target_m = s.state().positions_m.col(55) + Eigen::Vector3d(0.0, 0.1, 0.0);
         std::string error;
         ASSERT_TRUE(s.grab(hand, &error)) << error;
       }},
      {"a new wind", [](Simulation& s) { s.setWindVelocity(Eigen::Vector3d(0.0, 2.0, 0.0)); }},
      {"a retune", [](Simulation& s) {
         SceneOptions tuned = s.options();
         tuned.gravity_m_per_s2 *= 1.5;
         std::string error;
         ASSERT_TRUE(s.retune(tuned, &error)) << error;
       }},
      {"a gripper attached", [](Simulation& s) {
         GripperRequest hand;
         hand.id = 4;
         hand.frame = "hand";
         hand.pose.position_m = s.state().positions_m.col(95);
         hand.radius_m = 0.01;
         std::vector<int> held;
         std::string error;
         ASSERT_TRUE(s.attachGripper(hand, &held, &error)) << error;
       }},
      {"a state put in", [](Simulation& s) {
         ClothState moved = s.state();
         moved.positions_m.row(1).array() += 0.05;
         std::string error;
         ASSERT_TRUE(s.restoreState(moved, &error)) << error;
       }},
  };
  for (const Waker& waker : wakers) {
    std::unique_ptr<Simulation> simulation = sleepingHangingCloth();
    ASSERT_TRUE(simulation->advanceFrame().asleep) << waker.name;
    waker.apply(*simulation);
    const FrameReport report = simulation->advanceFrame();
    EXPECT_FALSE(report.asleep) << waker.name << " did not wake it";
    EXPECT_GT(report.substeps_used, 0) << waker.name;
  }
}

TEST(Sleep, AGrabWakesItAndTheClothFollowsTheHand) {
  std::unique_ptr<Simulation> simulation = sleepingHangingCloth();
  const Eigen::Vector3d before = simulation->state().positions_m.col(95);
  GraspRequest hand;
  hand.id = 1;
  hand.particle = 95;
  hand.target_m = before + Eigen::Vector3d(0.0, 0.2, 0.1);
  std::string error;
  ASSERT_TRUE(simulation->grab(hand, &error)) << error;
  for (int frame = 0; frame < 50; ++frame) EXPECT_FALSE(simulation->advanceFrame().asleep) << "frame " << frame;
  EXPECT_GT((simulation->state().positions_m.col(95) - before).norm(), 0.1) << "the held particle did not follow";
}

TEST(Sleep, AGripperOrLinkHeldStillLetsItSleepAndMovingItWakesIt) {
  SceneOptions options = loadBuiltinScene("hanging");
  FrameCollider forearm;
  forearm.frame = "forearm";
  forearm.shape = ShapeKind::kSphere;
  forearm.radius_m = 0.05;
  options.colliders.frames = {forearm};
  std::unique_ptr<Simulation> simulation = sleepingHangingCloth(options);
  GripperRequest hand;
  hand.id = 4;
  hand.frame = "hand";
  hand.pose.position_m = simulation->state().positions_m.col(95);
  hand.radius_m = 0.01;
  std::vector<int> held;
  std::string error;
  ASSERT_TRUE(simulation->attachGripper(hand, &held, &error)) << error;
  Pose far_away;
  far_away.position_m = Eigen::Vector3d(5.0, 5.0, 5.0);
  ASSERT_TRUE(simulation->moveFrameCollider(0, far_away, &error)) << error;
  // The node moves both to where tf says every frame, the same pose while they hold still.
  const auto holdStill = [&]() {
    ASSERT_TRUE(simulation->moveGripper(hand.id, hand.pose, &error)) << error;
    ASSERT_TRUE(simulation->moveFrameCollider(0, far_away, &error)) << error;
  };
  bool slept = false;
  for (int frame = 0; frame < kMostFramesToSleep && !slept; ++frame) {
    holdStill();
    slept = simulation->advanceFrame().asleep;
  }
  ASSERT_TRUE(slept) << "a gripper and a link held still kept the cloth awake";
  Pose lifted = hand.pose;
  lifted.position_m.z() += 0.01;
  ASSERT_TRUE(simulation->moveGripper(hand.id, lifted, &error)) << error;
  ASSERT_TRUE(simulation->moveFrameCollider(0, far_away, &error)) << error;
  EXPECT_FALSE(simulation->advanceFrame().asleep) << "the gripper moved and the cloth slept on";
  hand.pose = lifted;
  slept = false;
  for (int frame = 0; frame < kMostFramesToSleep && !slept; ++frame) {
    holdStill();
    slept = simulation->advanceFrame().asleep;
  }
  ASSERT_TRUE(slept);
  Pose nearer = far_away;
  nearer.position_m.x() -= 0.5;
  ASSERT_TRUE(simulation->moveGripper(hand.id, hand.pose, &error)) << error;
  ASSERT_TRUE(simulation->moveFrameCollider(0, nearer, &error)) << error;
  EXPECT_FALSE(simulation->advanceFrame().asleep) << "the link moved and the cloth slept on";
}

TEST(Sleep, ADrivenClothNeverSleeps) {
  SceneOptions swinging = loadBuiltinScene("hanging");
  swinging.rows = swinging.cols = 10;
  swinging.pin_motion_amplitude_m = Eigen::Vector3d(0.0, 1e-4, 0.0);  // a tenth of a millimetre
  swinging.pin_motion_period_s = 20.0;
  SceneOptions gusts = loadBuiltinScene("hanging");
  gusts.rows = gusts.cols = 10;
  gusts.wind_enabled = true;
  gusts.wind.velocity_m_per_s = Eigen::Vector3d(0.0, 1e-3, 0.0);
  gusts.wind.gust_amplitude = 0.5;
  SceneOptions never = smallDrop();
  never.sleep_speed_m_per_s = 0.0;
  for (const SceneOptions& options : {swinging, gusts, never}) {
    Simulation simulation(options);
    EXPECT_EQ(framesUntilAsleep(simulation), -1) << options.name << ": slept";
  }
  // A sphere drifting towards the sheet lying on the floor, still far from it.
  SceneOptions drifting = smallDrop();
  SphereCollider ball;
  ball.center_m = Eigen::Vector3d(100.0, 0.0, 0.0);
  ball.radius_m = 0.1;
  ball.velocity_m_per_s = Eigen::Vector3d(-1e-3, 0.0, 0.0);
  drifting.colliders.spheres = {ball};
  Simulation simulation(drifting);
  EXPECT_EQ(framesUntilAsleep(simulation), -1) << "slept with a sphere moving";
}

TEST(Sleep, ARunSavedAsleepContinuesBitExactlyThroughAFileAndWakesTheSame) {
  Simulation original(smallDrop());
  ASSERT_GE(framesUntilAsleep(original), 0);
  SimulationSnapshot through_file;
  std::string error;
  ASSERT_TRUE(decodeStateFile(encodeStateFile(original.snapshot()), &through_file, &error)) << error;
  Simulation restored(smallDrop());
  ASSERT_TRUE(restored.restore(through_file, &error)) << error;
  for (int frame = 0; frame < 120; ++frame) {
    if (frame == 20) {
      for (Simulation* simulation : {&original, &restored}) {
        GraspRequest hand;
        hand.id = 2;
        hand.particle = 0;
        hand.target_m = simulation->state().positions_m.col(0) + Eigen::Vector3d(0.0, 0.0, 0.2);
        ASSERT_TRUE(simulation->grab(hand, &error)) << error;
      }
    }
    if (frame == 40) {
      ASSERT_TRUE(original.release(2));
      ASSERT_TRUE(restored.release(2));
    }
    const FrameReport a = original.advanceFrame();
    const FrameReport b = restored.advanceFrame();
    ASSERT_EQ(a.asleep, b.asleep) << "frame " << frame;
    if (frame < 20) ASSERT_TRUE(a.asleep) << "frame " << frame;
    if (frame >= 20 && frame < 40 + original.options().sleepAfterFrames()) ASSERT_FALSE(a.asleep) << "frame " << frame;
    ASSERT_TRUE(original.state().positions_m == restored.state().positions_m) << "frame " << frame;
    ASSERT_TRUE(original.state().velocities_m_per_s == restored.state().velocities_m_per_s) << "frame " << frame;
  }
}

TEST(Sleep, SleepSpeedIsValidatedAndReadFromTheScene) {
  SceneOptions options = smallDrop();
  options.sleep_speed_m_per_s = -1e-4;
  ASSERT_FALSE(validateSceneOptions(options).empty());
  EXPECT_NE(validateSceneOptions(options).front().find("sleep_speed"), std::string::npos);
  options.sleep_speed_m_per_s = 2.0 * OptionLimits::kMaxSleepSpeed_m_per_s;
  EXPECT_FALSE(validateSceneOptions(options).empty());
  options.sleep_speed_m_per_s = 0.0;
  EXPECT_TRUE(validateSceneOptions(options).empty());
  EXPECT_EQ(SceneOptions().sleep_speed_m_per_s, SceneOptions::kDefaultSleepSpeed_m_per_s);
}

}  // namespace
}  // namespace cloth_sim::core
