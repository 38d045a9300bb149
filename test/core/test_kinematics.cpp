// Kinematics: bodies with a pose over the frame, particles held rigidly on them, and today's scripted
// motions (pins' hooks, swinging spheres) as bodies, the same bits as the closed forms they replace.
#include "cloth_sim/core/kinematics.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

namespace cloth_sim::core {
namespace {

bool sameBits(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::memcmp(a.data(), b.data(), 3 * sizeof(double)) == 0;
}

/// The smoothstep share of a travel still to go at time t of a travel lasting T (today's closed form).
double remainingTravel(double t, double T) {
  if (T <= 0.0 || t >= T) return 0.0;
  const double u = t / T;
  return 1.0 - u * u * (3.0 - 2.0 * u);
}

PoseTrack quarterTurnTrack() {
  PoseTrack track;
  track.start.position_m = Eigen::Vector3d(0.1, -0.2, 1.0);
  track.end.position_m = Eigen::Vector3d(0.5, 0.2, 0.8);
  track.end.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(kTwoPi / 4.0, Eigen::Vector3d::UnitZ()));
  track.start_time_s = 2.0;
  track.duration_s = 0.02;
  return track;
}

TEST(PoseTrack, InterpolatesThePositionLinearlyAndTheRotationBySlerp) {
  const PoseTrack track = quarterTurnTrack();
  EXPECT_TRUE(sameBits(track.at(0.0).position_m, track.start.position_m));
  EXPECT_TRUE(sameBits(track.at(1.0).position_m, track.end.position_m));
  const Pose quarter = track.at(0.25);
  EXPECT_LT((quarter.position_m - Eigen::Vector3d(0.2, -0.1, 0.95)).norm(), 1e-15);
  // A quarter of the way through a quarter turn about z: 22.5 degrees about z.
  const Eigen::Quaterniond expected(Eigen::AngleAxisd(kTwoPi / 16.0, Eigen::Vector3d::UnitZ()));
  EXPECT_LT(quarter.orientation.angularDistance(expected), 1e-12);
  // By time: the middle of the frame is s = 1/2.
  EXPECT_LT((track.atTime(2.01).position_m - track.at(0.5).position_m).norm(), 1e-12);
}

TEST(PoseTrack, TakesTheShorterWayRoundLikeItsTwist) {
  PoseTrack track;
  track.end.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.75 * kTwoPi, Eigen::Vector3d::UnitX()));
  track.duration_s = 1.0;
  // Three quarters of a turn one way is a quarter turn the other way.
  EXPECT_NEAR(track.twist().angular_rad_per_s.norm(), kTwoPi / 4.0, 1e-12);
  EXPECT_LT(track.twist().angular_rad_per_s.dot(Eigen::Vector3d::UnitX()), 0.0);
}

TEST(PoseTrack, ItsTwistIsTheDerivativeOfEveryHeldPoint) {
  const PoseTrack track = quarterTurnTrack();
  const Twist twist = track.twist();
  EXPECT_LT((twist.linear_m_per_s - Eigen::Vector3d(20.0, 20.0, -10.0)).norm(), 1e-9);
  EXPECT_LT((twist.angular_rad_per_s - Eigen::Vector3d(0.0, 0.0, kTwoPi / 4.0 / 0.02)).norm(), 1e-9);
  const Eigen::Vector3d local_m(0.3, -0.1, 0.2);
  const double ds = 1e-6;
  for (const double s : {0.1, 0.5, 0.9}) {
    const Pose pose = track.at(s);
    const Eigen::Vector3d numeric =
        (track.at(s + ds).transform(local_m) - track.at(s - ds).transform(local_m)) / (2.0 * ds * track.duration_s);
    const Eigen::Vector3d analytic = twist.pointVelocity(pose.orientation * local_m);
    EXPECT_LT((numeric - analytic).norm(), 1e-5 * analytic.norm()) << "s = " << s;
  }
}

TEST(ScriptedMotion, ASphereSwingIsTheSameBitsAsItsClosedForm) {
  SphereCollider sphere;
  sphere.center_m = Eigen::Vector3d(0.3, -1.2, 0.7);
  sphere.velocity_m_per_s = Eigen::Vector3d(0.0, 0.8, 0.0);
  sphere.oscillation_amplitude_m = Eigen::Vector3d(0.25, 0.0, -0.1);
  sphere.oscillation_period_s = 1.7;
  for (const double t : {0.0, 0.013, 0.5, 1.0 / 3.0, 2.9, 41.0}) {
    const Eigen::Vector3d closed_center = sphere.center_m + sphere.velocity_m_per_s * t +
                                          sphere.oscillation_amplitude_m * std::sin(kTwoPi * t / sphere.oscillation_period_s);
    const double rate = kTwoPi / sphere.oscillation_period_s;
    const Eigen::Vector3d closed_velocity =
        sphere.velocity_m_per_s + sphere.oscillation_amplitude_m * (rate * std::cos(rate * t));
    EXPECT_TRUE(sameBits(sphere.centerAt(t), closed_center)) << "t = " << t;
    EXPECT_TRUE(sameBits(sphere.velocityAt(t), closed_velocity)) << "t = " << t;
  }
}

TEST(ScriptedMotion, APinsHookWithSwingAndTravelIsTheSameBitsAsItsClosedForm) {
  ScriptedMotion hook;
  hook.origin_m = Eigen::Vector3d(-0.3, 0.03, 1.5);
  hook.swing_amplitude_m = Eigen::Vector3d(0.1, 0.0, 0.02);
  hook.swing_period_s = 0.8;
  hook.travel_m = Eigen::Vector3d(-0.2, -0.03, 0.0);
  hook.travel_time_s = 1.0;
  for (const double t : {0.0, 0.02, 0.37, 0.5, 0.99, 1.0, 3.3}) {
    const Eigen::Vector3d swing_m = hook.swing_amplitude_m * std::sin(kTwoPi * t / hook.swing_period_s);
    const Eigen::Vector3d closed = hook.origin_m + swing_m + remainingTravel(t, hook.travel_time_s) * hook.travel_m;
    EXPECT_TRUE(sameBits(hook.positionAt(t), closed)) << "t = " << t;
  }
  // Arrived: from the travel's end on it swings about its hook.
  EXPECT_EQ(hook.travelShare(1.0).remaining, 0.0);
  EXPECT_EQ(hook.travelShare(0.0).remaining, 1.0);
}

/// The largest speed |velocityAt| takes over [0, horizon], sampled every horizon / samples.
double sampledPeakSpeed(const ScriptedMotion& motion, double horizon_s, int samples) {
  double peak = 0.0;
  for (int k = 0; k <= samples; ++k) peak = std::max(peak, motion.velocityAt(horizon_s * k / samples).norm());
  return peak;
}

TEST(ScriptedMotion, ItsPeakSpeedIsTheSampledMaximumOfEachMotionAndBoundsTheirSum) {
  ScriptedMotion swing;
  swing.swing_amplitude_m = Eigen::Vector3d(0.3, 0.4, 0.0);  // |A| = 0.5 m
  swing.swing_period_s = 2.0;
  EXPECT_NEAR(sampledPeakSpeed(swing, 4.0, 200000), swing.peakSpeed_m_per_s(0.0), 1e-9);
  EXPECT_DOUBLE_EQ(swing.peakSpeed_m_per_s(0.0), 0.5 * kTwoPi / 2.0);

  ScriptedMotion travel;
  travel.travel_m = Eigen::Vector3d(0.0, 0.6, -0.8);  // 1 m
  travel.travel_time_s = 0.5;
  // The smoothstep peaks at 1.5 x the mean speed, at half time.
  EXPECT_NEAR(sampledPeakSpeed(travel, 0.5, 200000), travel.peakSpeed_m_per_s(0.0), 1e-9);
  EXPECT_DOUBLE_EQ(travel.peakSpeed_m_per_s(0.0), kSmoothstepPeakRate * 1.0 / 0.5);
  EXPECT_EQ(travel.peakSpeed_m_per_s(0.5), 0.0);  // arrived: no travel left

  ScriptedMotion all = swing;
  all.velocity_m_per_s = Eigen::Vector3d(0.0, 0.0, 0.2);
  all.travel_m = travel.travel_m;
  all.travel_time_s = travel.travel_time_s;
  const double sampled = sampledPeakSpeed(all, 4.0, 400000);
  EXPECT_LE(sampled, all.peakSpeed_m_per_s(0.0));
  EXPECT_GT(sampled, 0.5 * all.peakSpeed_m_per_s(0.0));
}

TEST(Kinematics, AParticleHeldOnABodyTurningAboutAnAxisThroughNoneOfThemMovesRigidly) {
  // The fabric_simulator bug (TESTING.md): rotations applied in the wrong order only show when the axis
  // misses the held particles. A body at (1, 0, 0.5) turns 90 degrees about z and moves; the particles sit
  // around the world origin, 1 m from the axis.
  const Eigen::Vector3d pivot_m(1.0, 0.0, 0.5);
  const Eigen::Vector3d shift_m(0.2, -0.1, 0.3);
  const Eigen::AngleAxisd quarter(kTwoPi / 4.0, Eigen::Vector3d::UnitZ());
  PoseTrack track;
  track.start.position_m = pivot_m;
  track.end.position_m = pivot_m + shift_m;
  track.end.orientation = Eigen::Quaterniond(quarter);
  track.duration_s = 0.1;
  Kinematics kinematics;
  const std::size_t body = kinematics.addBody({"hand", track});
  Eigen::Matrix3Xd start_m(3, 3);
  start_m << 0.0, 0.1, -0.05, 0.0, 0.0, 0.08, 0.0, 0.02, 0.0;
  const std::vector<int> held{4, 1, 9};
  kinematics.attach({body, held, start_m.colwise() - pivot_m});  // offsets in the body's frame (unrotated at start)
  EXPECT_EQ(kinematics.heldParticles(body), 3);

  Eigen::VectorXd inverse_mass = Eigen::VectorXd::Ones(10);
  kinematics.maskConstrained(inverse_mass);
  for (int i = 0; i < 10; ++i) {
    const bool is_held = i == 1 || i == 4 || i == 9;
    EXPECT_EQ(inverse_mass[i], is_held ? 0.0 : 1.0) << i;
  }

  ClothState state;
  state.positions_m.setZero(3, 10);
  state.velocities_m_per_s.setZero(3, 10);
  for (const double s : {0.0, 0.3, 0.5, 1.0}) {
    const double time_s = s * track.duration_s;
    kinematics.enforce(time_s, state);
    // Independently: rotate each start position about the pivot by s x 90 degrees, then shift by s x shift.
    const Eigen::AngleAxisd turned(s * quarter.angle(), quarter.axis());
    const Eigen::Vector3d omega = quarter.axis() * (quarter.angle() / track.duration_s);
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d lever = turned * (start_m.col(k) - pivot_m);
      const Eigen::Vector3d expected = pivot_m + s * shift_m + lever;
      EXPECT_LT((state.positions_m.col(held[k]) - expected).norm(), 1e-12) << "s = " << s << ", particle " << held[k];
      const Eigen::Vector3d expected_velocity = shift_m / track.duration_s + omega.cross(lever);
      EXPECT_LT((state.velocities_m_per_s.col(held[k]) - expected_velocity).norm(), 1e-10);
    }
    // Rigid: distances between held particles never change.
    EXPECT_NEAR((state.positions_m.col(4) - state.positions_m.col(9)).norm(), (start_m.col(0) - start_m.col(2)).norm(),
                1e-12);
  }
  for (int i : {0, 2, 3, 5}) EXPECT_TRUE(state.positions_m.col(i).isZero(0.0));  // free particles untouched

  // Its peak speed bounds every held particle's: |v| + |omega| x the longest lever.
  const double peak = kinematics.peakSpeed_m_per_s(body, 0.0);
  double fastest = 0.0;
  for (int k = 0; k < 3; ++k) fastest = std::max(fastest, state.velocities_m_per_s.col(held[k]).norm());
  EXPECT_LE(fastest, peak);
  EXPECT_GT(fastest, 0.8 * peak);
}

TEST(Kinematics, PinsOnTheirHooksAreMaskedAndPrescribedAsTodaysClosedFormsSay) {
  SceneOptions o;
  o.rows = 6;
  o.cols = 5;
  o.pins = {"top_edge"};
  o.pin_positions_m = {{-0.4, 0.0, 1.5}, {-0.2, 0.01, 1.5}, {0.0, 0.0, 1.5}, {0.2, -0.01, 1.5}, {0.4, 0.0, 1.5}};
  o.pin_travel_time_s = 0.5;
  o.pin_motion_amplitude_m = Eigen::Vector3d(0.05, 0.0, 0.02);
  o.pin_motion_period_s = 0.7;
  Simulation sim(o);
  GraspRequest grab;
  grab.id = 3;
  grab.particle = 2;  // a pin: off its hook while held
  grab.target_m = Eigen::Vector3d(0.0, 0.2, 1.6);
  std::string error;
  ASSERT_TRUE(sim.grab(grab, &error)) << error;

  const Kinematics& kinematics = sim.forceModel().kinematics();
  const Eigen::VectorXd& inverse_mass = sim.forceModel().inverseMass_per_kg();
  const ClothInputs& inputs = sim.inputs();
  ASSERT_EQ(inputs.pins, (std::vector<int>{0, 1, 2, 3, 4}));
  for (int i = 0; i < sim.grid().particleCount(); ++i) {
    const bool hooked = i < 5 && i != 2;
    EXPECT_EQ(inverse_mass[i] == 0.0, hooked) << i;
  }
  EXPECT_EQ(kinematics.bodies().size(), 4u);  // four hooks, no spheres

  for (const double t : {0.0, 0.1, 0.25, 0.49, 0.5, 1.3}) {
    Eigen::Matrix3Xd positions = Eigen::Matrix3Xd::Constant(3, sim.grid().particleCount(), 7.0);
    kinematics.prescribedPositions(t, positions);
    const Eigen::Vector3d swing_m = o.pin_motion_amplitude_m * std::sin(kTwoPi * t / o.pin_motion_period_s);
    for (std::size_t p = 0; p < inputs.pins.size(); ++p) {
      const int i = inputs.pins[p];
      const Eigen::Vector3d column = positions.col(i);
      if (i == 2) {
        EXPECT_TRUE(column.isConstant(7.0));  // held by the hand: free
        continue;
      }
      const Eigen::Vector3d closed = inputs.pin_anchors_m.col(p) + swing_m +
                                     remainingTravel(t, o.pin_travel_time_s) * inputs.pin_travel_m.col(p);
      EXPECT_TRUE(sameBits(column, closed)) << "t = " << t << ", pin " << i;
    }
    EXPECT_TRUE(positions.col(7).isConstant(7.0));
  }
  // Released, the pin hangs on a new hook where it was let go, and is prescribed again.
  ASSERT_TRUE(sim.release(3));
  EXPECT_EQ(sim.forceModel().inverseMass_per_kg()[2], 0.0);
  EXPECT_EQ(sim.forceModel().kinematics().bodies().size(), 5u);
}

TEST(Kinematics, SpheresAreBodiesWhosePeakSpeedIsTheirDriftPlusSwing) {
  SceneOptions o;
  SphereCollider sphere;
  sphere.center_m = Eigen::Vector3d(0.0, 0.5, 1.0);
  sphere.velocity_m_per_s = Eigen::Vector3d(0.0, -0.3, 0.0);
  sphere.oscillation_amplitude_m = Eigen::Vector3d(0.1, 0.0, 0.0);
  sphere.oscillation_period_s = 0.5;
  o.colliders.spheres = {sphere, sphere};
  o.colliders.spheres[1].velocity_m_per_s.setZero();
  Simulation sim(o);
  const Kinematics& kinematics = sim.forceModel().kinematics();
  ASSERT_EQ(kinematics.bodies().size(), 4u);  // two hooks (the default pins), two spheres
  for (std::size_t s = 0; s < 2; ++s) {
    const std::size_t body = kinematics.sphereBody(s);
    EXPECT_EQ(kinematics.heldParticles(body), 0);
    const SphereCollider& collider = o.colliders.spheres[s];
    EXPECT_DOUBLE_EQ(kinematics.peakSpeed_m_per_s(body, 0.0),
                     collider.velocity_m_per_s.norm() + 0.1 * kTwoPi / 0.5);
    EXPECT_TRUE(sameBits(kinematics.bodies()[body].poseAt(0.3).position_m, collider.centerAt(0.3)));
  }
}

}  // namespace
}  // namespace cloth_sim::core
