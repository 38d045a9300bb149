// A cloth at rest sleeps (SceneOptions::sleep_speed_m_per_s): it stops being computed once it has stood
// still for SceneOptions::kSleepAfter_s with nothing driving it, keeps its state bit for bit while asleep
// (but for one frame computed per SceneOptions::kSleepCheckPeriod_s), and wakes on anything that would
// move it.
#include "cloth_sim/core/scripted_fold.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/state_file.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace cloth_sim::core {
namespace {

using test::loadBuiltinScene;

/// Frames a small cloth gets to come to rest (the sheet lands in about 1 s, the hanging cloth stops
/// swinging in about 2 s).
constexpr int kMostFramesToSleep = 500;

/// The `drop` scene at 12 x 12: a sheet that falls flat onto the floor and lies there.
SceneOptions smallDrop() {
  SceneOptions options = loadBuiltinScene("drop");
  options.rows = 12;
  options.cols = 12;
  return options;
}

SceneOptions smallHanging() {
  SceneOptions options = loadBuiltinScene("hanging");
  options.rows = 10;
  options.cols = 10;
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

/// Whether the frame just advanced to is one a sleeping cloth is computed on.
bool isCheckFrame(const Simulation& simulation) {
  return simulation.state().frame % static_cast<std::uint64_t>(Simulation::sleepCheckFrames(simulation.options())) == 0;
}

TEST(Sleep, ASheetLyingOnTheFloorFallsAsleepAndKeepsItsStateBitForBitBetweenChecks) {
  Simulation simulation(smallDrop());
  const int computed = framesUntilAsleep(simulation);
  ASSERT_GE(computed, Simulation::sleepAfterFrames(simulation.options()))
      << "never slept, or slept before it was seen at rest";
  ClothState last = simulation.state();
  const int substeps = simulation.lastFrameSubsteps();
  int checks = 0;
  for (int frame = 1; frame <= 120; ++frame) {
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    if (isCheckFrame(simulation)) {
      // Computed once a second: the sheet is still at rest, so it sleeps on (what a report of the cloth
      // says: a node whose 1 Hz diagnostics fell on the check frames read asleep False every time).
      EXPECT_FALSE(report.asleep) << "frame " << simulation.state().frame << " is a check frame";
      EXPECT_TRUE(report.sleeping) << "frame " << simulation.state().frame << " found it at rest";
      EXPECT_GT(report.substeps_used, 0);
      EXPECT_LE((simulation.state().positions_m - simulation.guardMemory().calm_anchor_m).colwise().norm().maxCoeff(),
                Simulation::sleepAllowance_m(simulation.options()));
      last = simulation.state();
      ++checks;
      continue;
    }
    ASSERT_TRUE(report.asleep) << "frame " << simulation.state().frame << " woke with nothing to wake it";
    EXPECT_TRUE(report.sleeping);
    EXPECT_EQ(report.substeps_used, 0);
    EXPECT_EQ(report.steps.solver_iterations, 0);
    EXPECT_TRUE(simulation.state().positions_m == last.positions_m) << "frame " << simulation.state().frame;
    EXPECT_TRUE(simulation.state().velocities_m_per_s == last.velocities_m_per_s);
    EXPECT_EQ(simulation.state().frame, last.frame + 1);
    EXPECT_NEAR(simulation.state().time_s, last.time_s + simulation.options().frameDuration_s(), 1e-9);
    last = simulation.state();
  }
  EXPECT_EQ(checks, 120 / Simulation::sleepCheckFrames(simulation.options()));
  EXPECT_EQ(simulation.lastFrameSubsteps(), substeps);
}

TEST(Sleep, WhatItSleepsThroughIsWhatTheComputedRunDoesToWithinTheSleepSpeed) {
  for (const SceneOptions& options : {smallDrop(), smallHanging()}) {
    SceneOptions never = options;
    never.sleep_speed_m_per_s = 0.0;
    Simulation sleeping(options);
    Simulation computed(never);
    constexpr int kFrames = 400;  // 8 s: asleep for most of it
    int slept = 0;
    for (int frame = 0; frame < kFrames; ++frame) {
      slept += sleeping.advanceFrame().asleep ? 1 : 0;
      EXPECT_FALSE(computed.advanceFrame().asleep) << "sleep_speed 0 slept";
    }
    ASSERT_GT(slept, kFrames / 2) << options.name;
    // Had it fallen asleep while still moving (faster than sleep_speed), the computed run would have gone
    // on without it; once at rest, computed, these two cloths stand still (an exact rest: a check frame of
    // theirs that moved more than sleep_speed in a frame would wake them).
    const double seconds_asleep = slept * options.frameDuration_s();
    const double apart_m = (sleeping.state().positions_m - computed.state().positions_m).colwise().norm().maxCoeff();
    EXPECT_LT(apart_m, options.sleep_speed_m_per_s * seconds_asleep) << options.name;
    std::printf("[ sleep      ] %s: asleep %d of %d frames, %.3g m from the computed run\n", options.name.c_str(),
                slept, kFrames, apart_m);
  }
}

/// What is done to a cloth before it sleeps, and what wakes it.
struct Waker {
  const char* name;
  std::function<void(Simulation&)> before_sleep;
  std::function<void(Simulation&)> wake;
};

GraspRequest handOn(const Simulation& simulation, int particle, const Eigen::Vector3d& offset_m) {
  GraspRequest hand;
  hand.id = 9;
  hand.particle = particle;
  hand.target_m = simulation.state().positions_m.col(particle) + offset_m;
  return hand;
}

GripperRequest gripperOn(const Simulation& simulation, int particle) {
  GripperRequest gripper;
  gripper.id = 4;
  gripper.frame = "hand";
  gripper.pose.position_m = simulation.state().positions_m.col(particle);
  gripper.radius_m = 0.01;
  return gripper;
}

TEST(Sleep, EveryInputWakesItBeforeTheNextFrameAndTheClothMoves) {
  constexpr int kParticle = 95;  // the hanging 10 x 10 cloth's bottom row: free
  const auto nothing = [](Simulation&) {};
  const std::vector<Waker> wakers{
      {"a grab", nothing,
       [](Simulation& s) {
         std::string error;
         ASSERT_TRUE(s.grab(handOn(s, kParticle, Eigen::Vector3d(0.0, 0.1, 0.0)), &error)) << error;
       }},
      {"a drag (the same grasp, a new target)",
       [](Simulation& s) {
         std::string error;
         ASSERT_TRUE(s.grab(handOn(s, kParticle, Eigen::Vector3d::Zero()), &error)) << error;
       },
       [](Simulation& s) {
         std::string error;
         GraspRequest hand = handOn(s, kParticle, Eigen::Vector3d(0.0, 0.1, 0.0));
         hand.target_m = s.grasps().front().target_m + Eigen::Vector3d(0.0, 0.1, 0.0);
         ASSERT_TRUE(s.grab(hand, &error)) << error;
       }},
      {"a release",
       [](Simulation& s) {
         std::string error;
         ASSERT_TRUE(s.grab(handOn(s, kParticle, Eigen::Vector3d(0.0, 0.05, 0.05)), &error)) << error;
       },
       [](Simulation& s) { ASSERT_TRUE(s.release(9)); }},
      {"a new wind", nothing, [](Simulation& s) { s.setWindVelocity(Eigen::Vector3d(0.0, 2.0, 0.0)); }},
      {"a retune", nothing,
       [](Simulation& s) {
         SceneOptions tuned = s.options();
         tuned.gravity_m_per_s2 *= 1.5;
         std::string error;
         ASSERT_TRUE(s.retune(tuned, &error)) << error;
       }},
      {"a gripper attached", nothing,
       [](Simulation& s) {
         std::vector<int> held;
         std::string error;
         GripperRequest gripper = gripperOn(s, kParticle);
         gripper.pose.position_m.y() += 0.005;  // its particle keeps its offset: the gripper holds it still
         ASSERT_TRUE(s.attachGripper(gripper, &held, &error)) << error;
         // ... and then carries it.
         Pose moved = gripper.pose;
         moved.position_m.y() += 0.05;
         ASSERT_TRUE(s.moveGripper(gripper.id, moved, &error)) << error;
       }},
      {"a gripper detached",
       [](Simulation& s) {
         std::vector<int> held;
         std::string error;
         GripperRequest gripper = gripperOn(s, kParticle);
         ASSERT_TRUE(s.attachGripper(gripper, &held, &error)) << error;
         Pose lifted = gripper.pose;
         lifted.position_m.z() += 0.05;
         ASSERT_TRUE(s.moveGripper(gripper.id, lifted, &error)) << error;
       },
       [](Simulation& s) { ASSERT_TRUE(s.detachGripper(4)); }},
      {"a reset", nothing, [](Simulation& s) { s.reset(); }},
      {"a state put in", nothing,
       [](Simulation& s) {
         ClothState moved = s.state();
         moved.positions_m.row(1).array() += 0.05;
         std::string error;
         ASSERT_TRUE(s.restoreState(moved, &error)) << error;
       }},
  };
  for (const Waker& waker : wakers) {
    Simulation simulation(smallHanging());
    waker.before_sleep(simulation);
    ASSERT_GE(framesUntilAsleep(simulation), 0) << waker.name << ": never slept";
    ASSERT_TRUE(simulation.advanceFrame().asleep) << waker.name;
    waker.wake(simulation);
    const ClothState woken = simulation.state();
    const FrameReport report = simulation.advanceFrame();
    EXPECT_FALSE(report.asleep) << waker.name << " did not wake it";
    EXPECT_FALSE(report.sleeping) << waker.name << " woke it, but the report says it sleeps";
    EXPECT_GT(report.substeps_used, 0) << waker.name;
    for (int frame = 0; frame < 10; ++frame) EXPECT_FALSE(simulation.advanceFrame().asleep) << waker.name;
    EXPECT_GT((simulation.state().positions_m - woken.positions_m).colwise().norm().maxCoeff(), 1e-4)
        << waker.name << ": the cloth did not move";
  }
}

/// The small hanging cloth with a sphere on a tf frame (a robot link), not yet posed.
SceneOptions hangingWithASphereLink(const std::string& frame, double radius_m) {
  SceneOptions options = smallHanging();
  FrameCollider link;
  link.frame = frame;
  link.shape = ShapeKind::kSphere;
  link.radius_m = radius_m;
  options.colliders.frames = {link};
  return options;
}

TEST(Sleep, AGripperAndALinkHeldStillLetItSleepWhateverTheirRoundingAndMovingEitherWakesIt) {
  Simulation simulation(hangingWithASphereLink("forearm", 0.05));
  std::vector<int> held;
  std::string error;
  const GripperRequest gripper = gripperOn(simulation, 95);
  ASSERT_TRUE(simulation.attachGripper(gripper, &held, &error)) << error;
  Pose far_away;
  far_away.position_m = Eigen::Vector3d(5.0, 5.0, 5.0);
  // The node moves both to where tf says every frame: interpolating between two equal transforms, tf may
  // differ from them in the last bit, frame to frame.
  int frame_count = 0;
  const auto holdStill = [&](const Pose& hand, const Pose& link) {
    Pose jittered_hand = hand;
    Pose jittered_link = link;
    const double ulp_m = frame_count++ % 2 == 0 ? 0.0 : 1e-16;
    jittered_hand.position_m.x() += ulp_m;
    jittered_link.position_m.y() += ulp_m;
    ASSERT_TRUE(simulation.moveGripper(gripper.id, jittered_hand, &error)) << error;
    ASSERT_TRUE(simulation.moveFrameCollider(0, jittered_link, &error)) << error;
  };
  const auto sleepsWhileHeld = [&](const Pose& hand, const Pose& link) {
    for (int frame = 0; frame < kMostFramesToSleep; ++frame) {
      holdStill(hand, link);
      if (simulation.advanceFrame().asleep) return true;
    }
    return false;
  };
  ASSERT_TRUE(sleepsWhileHeld(gripper.pose, far_away)) << "a gripper and a link held still kept the cloth awake";
  Pose lifted = gripper.pose;
  lifted.position_m.z() += 0.01;
  ASSERT_TRUE(simulation.moveGripper(gripper.id, lifted, &error)) << error;
  ASSERT_TRUE(simulation.moveFrameCollider(0, far_away, &error)) << error;
  EXPECT_FALSE(simulation.advanceFrame().asleep) << "the gripper moved and the cloth slept on";
  ASSERT_TRUE(sleepsWhileHeld(lifted, far_away));
  Pose nearer = far_away;
  nearer.position_m.x() -= 0.5;
  ASSERT_TRUE(simulation.moveGripper(gripper.id, lifted, &error)) << error;
  ASSERT_TRUE(simulation.moveFrameCollider(0, nearer, &error)) << error;
  EXPECT_FALSE(simulation.advanceFrame().asleep) << "the link moved and the cloth slept on";
}

TEST(Sleep, ALinkFirstSeenInsideTheClothWakesIt) {
  Simulation simulation(hangingWithASphereLink("ball", 0.1));
  ASSERT_GE(framesUntilAsleep(simulation), 0);
  Pose on_the_cloth;
  on_the_cloth.position_m = simulation.state().positions_m.col(45);
  const ClothState before = simulation.state();
  std::string error;
  ASSERT_TRUE(simulation.moveFrameCollider(0, on_the_cloth, &error)) << error;
  EXPECT_FALSE(simulation.advanceFrame().asleep) << "a link that appeared did not wake the cloth";
  // Its first pose places it; from the next frame on it pushes the cloth out of itself.
  for (int frame = 0; frame < 10; ++frame) EXPECT_FALSE(simulation.advanceFrame().asleep);
  EXPECT_GT((simulation.state().positions_m - before.positions_m).colwise().norm().maxCoeff(), 1e-3)
      << "the link did not push the cloth";
}

TEST(Sleep, ADrivenClothNeverSleeps) {
  SceneOptions swinging = smallHanging();
  swinging.pin_motion_amplitude_m = Eigen::Vector3d(0.0, 1e-4, 0.0);  // a tenth of a millimetre
  swinging.pin_motion_period_s = 20.0;
  SceneOptions gusts = smallHanging();
  gusts.wind_enabled = true;
  gusts.wind.velocity_m_per_s = Eigen::Vector3d(0.0, 1e-3, 0.0);
  gusts.wind.gust_amplitude = 0.5;
  SceneOptions never = smallDrop();
  never.sleep_speed_m_per_s = 0.0;
  // A sphere drifting towards the sheet lying on the floor, still far from it.
  SceneOptions drifting = smallDrop();
  SphereCollider ball;
  ball.center_m = Eigen::Vector3d(100.0, 0.0, 0.0);
  ball.radius_m = 0.1;
  ball.velocity_m_per_s = Eigen::Vector3d(-1e-3, 0.0, 0.0);
  drifting.colliders.spheres = {ball};
  for (const SceneOptions& options : {swinging, gusts, never, drifting}) {
    Simulation simulation(options);
    EXPECT_EQ(framesUntilAsleep(simulation), -1) << options.name << ": slept";
  }
}

TEST(Sleep, ACalmGustlessWindLetsItSleep) {
  constexpr double kWind_m_per_s = 0.5;  // blown out of its plane, it comes to rest in about 14 s
  SceneOptions options = smallHanging();
  options.wind_enabled = true;
  options.wind.velocity_m_per_s = Eigen::Vector3d(0.0, kWind_m_per_s, 0.0);
  Simulation simulation(options);
  EXPECT_GE(framesUntilAsleep(simulation, 2 * kMostFramesToSleep), 0) << "a steady wind kept a cloth at rest awake";
}

TEST(Sleep, AClothJerkedToManySubstepsSleepsAndWakesAtOne) {
  // Grasp jerks raise `auto`'s scale (issue 18: up to 64); awake, a calm cloth tries half of it every 16th
  // frame. On its way to sleep it tries nothing (a trial may stir it), sleeps with the scale it has, and
  // wakes at one step a frame: what moves it then is not what the scale was raised for.
  Simulation simulation(smallHanging());
  ASSERT_GE(framesUntilAsleep(simulation), 0);
  SimulationSnapshot jerked = simulation.snapshot();
  jerked.guard.auto_scale = GuardMemory::kMaxScale;
  jerked.guard.forgetCalm();  // the jerks moved it
  std::string error;
  ASSERT_TRUE(simulation.restore(jerked, &error)) << error;
  ASSERT_GE(framesUntilAsleep(simulation), 0);
  EXPECT_EQ(simulation.guardMemory().auto_scale, GuardMemory::kMaxScale) << "a trial came on the way to sleep";
  ASSERT_TRUE(simulation.grab(handOn(simulation, 95, Eigen::Vector3d(0.0, 0.1, 0.0)), &error)) << error;
  const FrameReport woken = simulation.advanceFrame();
  EXPECT_FALSE(woken.asleep);
  EXPECT_EQ(woken.substeps_used, 1) << "woke with the jerks' scale";
  EXPECT_EQ(simulation.guardMemory().auto_scale, 1);
}

TEST(Sleep, ARunSavedAsleepContinuesBitExactlyThroughAFileAndWakesTheSame) {
  Simulation original(smallDrop());
  ASSERT_GE(framesUntilAsleep(original), 0);
  SimulationSnapshot through_file;
  std::string error;
  ASSERT_TRUE(decodeStateFile(encodeStateFile(original.snapshot()), &through_file, &error)) << error;
  Simulation restored(smallDrop());
  ASSERT_TRUE(restored.restore(through_file, &error)) << error;
  constexpr int kGrabFrame = 80;  // past a check frame
  for (int frame = 0; frame < 160; ++frame) {
    if (frame == kGrabFrame) {
      for (Simulation* simulation : {&original, &restored}) {
        ASSERT_TRUE(simulation->grab(handOn(*simulation, 0, Eigen::Vector3d(0.0, 0.0, 0.2)), &error)) << error;
      }
    }
    if (frame == kGrabFrame + 20) {
      ASSERT_TRUE(original.release(9));
      ASSERT_TRUE(restored.release(9));
    }
    const FrameReport a = original.advanceFrame();
    const FrameReport b = restored.advanceFrame();
    ASSERT_EQ(a.asleep, b.asleep) << "frame " << frame;
    if (frame < kGrabFrame) {
      ASSERT_EQ(a.asleep, !isCheckFrame(original)) << "frame " << frame;
    }
    if (frame >= kGrabFrame && frame < kGrabFrame + 20 + Simulation::sleepAfterFrames(original.options())) {
      ASSERT_FALSE(a.asleep) << "frame " << frame;
    }
    ASSERT_TRUE(original.state().positions_m == restored.state().positions_m) << "frame " << frame;
    ASSERT_TRUE(original.state().velocities_m_per_s == restored.state().velocities_m_per_s) << "frame " << frame;
  }
}

TEST(Sleep, AFoldedTowelJitteringInALimitCycleOfItsContactsSleepsAndStaysAsleep) {
  // The fold at 36 x 36 (self-collision, friction on the floor and between the layers) comes to rest in
  // a limit cycle: a particle of the lower layer flips about 5 um to and fro every frame, for good.
  // Measured frame to frame, it moved faster than sleep_speed in every frame and never slept (nor did a
  // 64 x 64 one in the node, 13 um a frame); measured from where the calm frames began, it stands still.
  constexpr int kSide = 36;
  constexpr int kMostFrames = 400;
  SceneOptions options = loadBuiltinScene("fold");
  options.rows = kSide;
  options.cols = kSide;
  Simulation simulation(options);
  const ScriptedFold fold;
  const double frame_step_m = options.sleep_speed_m_per_s * options.frameDuration_s();
  int slept_at = -1;
  // Frames in a row that moved less than sleep_speed, the rule measured frame to frame: the most of them.
  int still_in_a_row = 0;
  int most_still_in_a_row = 0;
  std::string error;
  for (int frame = 0; frame < kMostFrames && slept_at < 0; ++frame) {
    ASSERT_TRUE(fold.drive(simulation, &error)) << error;
    const Eigen::Matrix3Xd before = simulation.state().positions_m;
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    if (report.asleep) {
      slept_at = frame;
      break;
    }
    const double step_m = (simulation.state().positions_m - before).colwise().norm().maxCoeff();
    still_in_a_row = step_m <= frame_step_m ? still_in_a_row + 1 : 0;
    most_still_in_a_row = std::max(most_still_in_a_row, still_in_a_row);
  }
  ASSERT_GE(slept_at, 0) << "the folded towel never slept in " << kMostFrames << " frames";
  EXPECT_GT(slept_at, ScriptedFold().releaseTime_s() * options.frame_rate_hz) << "slept in the hands";
  ASSERT_LT(most_still_in_a_row, Simulation::sleepAfterFrames(options))
      << "the towel came to rest frame to frame: this test needs one jittering in a limit cycle";
  const double largest_calm_step_m = simulation.guardMemory().calm_largest_step_m;
  EXPECT_GT(largest_calm_step_m, frame_step_m) << "its rest, as the calm frames saw it, moved less than sleep_speed";
  // Asleep, the check frames (one a second) compute the cycle on: it stays within the allowance of where
  // the calm frames began, and sleeps on.
  const Eigen::Matrix3Xd anchor_m = simulation.guardMemory().calm_anchor_m;
  int checks = 0;
  for (int frame = 0; frame < 3 * Simulation::sleepCheckFrames(options); ++frame) {
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    if (isCheckFrame(simulation)) {
      ++checks;
      EXPECT_FALSE(report.asleep);
    } else {
      ASSERT_TRUE(report.asleep) << "woke " << frame << " frames after it fell asleep";
    }
    EXPECT_LE((simulation.state().positions_m - anchor_m).colwise().norm().maxCoeff(),
              Simulation::sleepAllowance_m(options));
  }
  EXPECT_EQ(checks, 3);
  std::printf("[ sleep      ] fold %dx%d: asleep at frame %d, jittering up to %.3g m a frame before it (at most %d "
              "frames in a row under sleep_speed)\n", kSide, kSide, slept_at, largest_calm_step_m, most_still_in_a_row);
}

TEST(Sleep, ASleepingClothThatBeginsToSlideWakesAtTheNextCheckFrame) {
  // One computed frame a second cannot tell a jitter from the start of a slide; measured from the calm
  // frames' anchor alone, a sheet sliding at 0.2 mm/s slept on for 14 s (the check frames adding up to
  // the 50 um). A check frame that moves further than the sheet's rest did wakes it.
  for (const double speed_m_per_s : {2e-4, 1e-3}) {
    SceneOptions options = smallDrop();
    options.contact.friction = 0.0;  // nothing holds it once it moves
    Simulation simulation(options);
    ASSERT_GE(framesUntilAsleep(simulation), 0);
    ASSERT_LE(simulation.guardMemory().calm_largest_step_m, options.sleep_speed_m_per_s * options.frameDuration_s())
        << "the sheet on the floor should come to an exact rest";
    // The sheet begins to slide along the floor while it sleeps (as a hem slipping off a table's edge
    // would): the same snapshot, asleep, with a velocity along x.
    SimulationSnapshot sliding = simulation.snapshot();
    sliding.state.velocities_m_per_s.row(0).setConstant(speed_m_per_s);
    std::string error;
    ASSERT_TRUE(simulation.restore(sliding, &error)) << error;
    int frames_to_wake = -1;
    for (int frame = 0; frame < 2 * Simulation::sleepCheckFrames(options); ++frame) {
      const FrameReport report = simulation.advanceFrame();
      ASSERT_TRUE(report.stable) << report.reason;
      if (isCheckFrame(simulation)) {
        frames_to_wake = simulation.guardMemory().calm_frames == 0 ? frame : -1;
        break;
      }
      ASSERT_TRUE(report.asleep) << "woke before the check frame";
    }
    EXPECT_GE(frames_to_wake, 0) << speed_m_per_s << " m/s: still asleep after its check frame";
    EXPECT_FALSE(simulation.advanceFrame().asleep) << speed_m_per_s << " m/s: the frame after the check slept";
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
