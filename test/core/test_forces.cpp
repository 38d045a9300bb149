// Paper §3 and §5: wind (both models), air damping, grasps and moving pins.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/forces.h"
#include "cloth_sim/core/simulation.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cloth_sim::core {
namespace {

/// One triangle (0,0,0), (1,0,0), (0,1,1): unit normal (0,-1,1)/sqrt(2), area sqrt(2)/2 m^2.
Eigen::Matrix3Xd tiltedTriangle() {
  Eigen::Matrix3Xd x(3, 3);
  x << 0, 1, 0,
       0, 0, 1,
       0, 0, 1;
  return x;
}

Eigen::Matrix3Xd windOn(const Eigen::Matrix3Xd& positions, const std::vector<int>& triangles, WindModel model,
                        const Eigen::Vector3d& wind) {
  WindOptions options;
  options.model = model;
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, positions.cols());
  const Eigen::Matrix3Xd still = Eigen::Matrix3Xd::Zero(3, positions.cols());
  accumulateWindForces(triangles, options, wind, positions, still, forces);
  return forces;
}

TEST(Wind, WindParallelToAFlatClothGivesNoForceInEitherModel) {
  const ClothGrid grid = buildClothGrid(5, 5, 1.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                        Eigen::Vector3d::UnitY());  // flat in z = 0
  for (WindModel model : {WindModel::kPaper, WindModel::kAerodynamic}) {
    const Eigen::Matrix3Xd f = windOn(grid.rest_positions_m, grid.triangles, model, Eigen::Vector3d(7.0, -3.0, 0.0));
    EXPECT_EQ(f.cwiseAbs().maxCoeff(), 0.0);
  }
}

TEST(Wind, PaperModelOnATiltedTriangleGivesTheHandComputedForce) {
  // F_w = c w = 0.001 * (0, 0, 10) N; (F_w . N) N = 0.01 / sqrt(2) * (0, -1, 1) / sqrt(2) = 0.005 (0, -1, 1) N,
  // a third on each corner.
  const Eigen::Matrix3Xd f = windOn(tiltedTriangle(), {0, 1, 2}, WindModel::kPaper, Eigen::Vector3d(0, 0, 10));
  const Eigen::Vector3d expected = 0.005 / 3.0 * Eigen::Vector3d(0, -1, 1);
  for (int i = 0; i < 3; ++i) EXPECT_LT((f.col(i) - expected).norm(), 1e-15) << f.col(i).transpose();
}

TEST(Wind, AerodynamicModelOnATiltedTriangleGivesTheHandComputedForce) {
  // v_rel . N = 10 / sqrt(2); F = 1/2 rho C_d A (v.N)^2 N = 0.5 * 1.2 * 1 * (sqrt(2)/2) * 50 N = 21.213 N along
  // N, i.e. 15 (0, -1, 1) N, a third on each corner.
  const Eigen::Matrix3Xd f = windOn(tiltedTriangle(), {0, 1, 2}, WindModel::kAerodynamic, Eigen::Vector3d(0, 0, 10));
  const Eigen::Vector3d expected = 5.0 * Eigen::Vector3d(0, -1, 1);
  for (int i = 0; i < 3; ++i) EXPECT_LT((f.col(i) - expected).norm(), 1e-12) << f.col(i).transpose();
}

TEST(Wind, AerodynamicModelFeelsOnlyTheWindRelativeToTheCloth) {
  // A triangle moving with the wind feels nothing; the paper's model ignores the cloth's motion.
  WindOptions options;
  options.model = WindModel::kAerodynamic;
  const Eigen::Vector3d wind(0, 0, 10);
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, 3);
  Eigen::Matrix3Xd with_the_wind(3, 3);
  with_the_wind.colwise() = wind;
  accumulateWindForces({0, 1, 2}, options, wind, tiltedTriangle(), with_the_wind, forces);
  EXPECT_EQ(forces.cwiseAbs().maxCoeff(), 0.0);
}

TEST(Wind, GustsScaleTheMeanWindSinusoidally) {
  WindOptions options;
  options.velocity_m_per_s = Eigen::Vector3d(2, 0, 0);
  options.gust_amplitude = 0.5;
  options.gust_period_s = 4.0;
  EXPECT_NEAR(windVelocityAt(options, 1.0).x(), 3.0, 1e-12);  // sin(pi/2) = 1
  EXPECT_NEAR(windVelocityAt(options, 3.0).x(), 1.0, 1e-12);
}

TEST(AirDamping, AloneItMakesKineticEnergyDecayAtTheClosedFormRate) {
  // Free particles (no springs, no gravity) with F = -K v: KE(t) = KE(0) exp(-2 K t / m), monotone.
  SceneOptions o = test::freeCloth(4, 4);
  for (SpringOptions& s : o.springs) s.enabled = false;
  o.air_damping_N_s_per_m = 0.02;  // 2 K / m = 1.28 /s: KE falls to 28 % in the 1 s run
  Simulation sim(o);
  ClothState kicked = sim.state();
  for (int i = 0; i < kicked.particleCount(); ++i) kicked.velocities_m_per_s.col(i) = Eigen::Vector3d(i % 3, 1, -0.5 * i);
  std::string error;
  ASSERT_TRUE(sim.restoreState(kicked, &error));
  const double m = sim.massPerParticle_kg()[0];
  const double e0 = sim.energies().kinetic_J;
  double previous = e0;
  for (int frame = 0; frame < 50; ++frame) {
    sim.advanceFrame();
    const double e = sim.energies().kinetic_J;
    EXPECT_LT(e, previous) << "frame " << frame;
    previous = e;
  }
  const double expected = e0 * std::exp(-2.0 * o.air_damping_N_s_per_m * sim.state().time_s / m);
  EXPECT_NEAR(previous, expected, 1e-3 * expected);
  EXPECT_LT(previous, 0.5 * e0);
}

TEST(Forces, ASwitchedOffTermContributesNothing) {
  // Everything off but gravity: a free cloth falls exactly as a rigid body, x = x0 + g t^2 / 2 (to the
  // first-order error of symplectic Euler, g h t / 2).
  SceneOptions o;
  o.rows = 5;
  o.cols = 5;
  o.pins.clear();
  for (SpringOptions& s : o.springs) s.enabled = false;
  o.air_damping_N_s_per_m = 0.0;
  o.wind_enabled = false;
  o.wind.velocity_m_per_s = Eigen::Vector3d(50, 0, 0);  // present but switched off
  Simulation sim(o);
  for (int frame = 0; frame < 25; ++frame) sim.advanceFrame();
  const double t = sim.state().time_s;
  const Eigen::Matrix3Xd drop = sim.state().positions_m - sim.grid().rest_positions_m;
  for (Eigen::Index i = 0; i < drop.cols(); ++i) {
    EXPECT_NEAR(drop(0, i), 0.0, 1e-15);
    EXPECT_NEAR(drop(1, i), 0.0, 1e-15);
    EXPECT_NEAR(drop(2, i), -0.5 * 9.81 * t * t, 0.5 * 9.81 * o.substep_s() * t + 1e-12);
  }
}

TEST(Grasp, GrabTheNearestParticleMoveItThenReleaseIt) {
  SceneOptions o;  // hanging: two top corners pinned
  o.rows = 10;
  o.cols = 10;
  Simulation sim(o);
  const int bottom_right = sim.grid().index(9, 9);
  GraspRequest request;
  request.id = 3;
  request.target_m = sim.state().positions_m.col(bottom_right) + Eigen::Vector3d(0.01, 0.0, -0.01);
  request.stiffness_N_per_m = 20.0;
  std::string error;
  ASSERT_TRUE(sim.grab(request, &error)) << error;
  ASSERT_EQ(sim.grasps().size(), 1u);
  EXPECT_EQ(sim.grasps()[0].particle, bottom_right) << "particle -1 picks the one nearest the target";

  // Drag the corner 0.4 m towards the viewer (-y): it follows (the spring balances the cloth's pull).
  request.target_m += Eigen::Vector3d(0.0, -0.4, 0.0);
  ASSERT_TRUE(sim.grab(request, &error));
  ASSERT_EQ(sim.grasps().size(), 1u) << "same id: the target moves, no second grasp";
  for (int frame = 0; frame < 150; ++frame) sim.advanceFrame();
  EXPECT_LT(sim.state().positions_m(1, bottom_right), -0.3);

  // Release: it swings back to hang below the pins.
  EXPECT_TRUE(sim.release(3));
  EXPECT_FALSE(sim.release(3)) << "already released";
  for (int frame = 0; frame < 400; ++frame) sim.advanceFrame();
  EXPECT_GT(sim.state().positions_m(1, bottom_right), -0.1);
}

TEST(Grasp, SeveralGraspsActAtOnceEachWithItsIdAndExtraForce) {
  SceneOptions o = test::freeCloth(8, 8);
  Simulation sim(o);
  const ClothGrid& g = sim.grid();
  GraspRequest left;
  left.id = 1;
  left.particle = g.index(7, 0);
  left.target_m = sim.state().positions_m.col(left.particle);
  GraspRequest right;
  right.id = 2;
  right.particle = g.index(7, 7);
  right.target_m = sim.state().positions_m.col(right.particle);
  right.extra_force_N = Eigen::Vector3d(0, 0.5, 0);  // only this hand pushes along +y
  std::string error;
  ASSERT_TRUE(sim.grab(left, &error));
  ASSERT_TRUE(sim.grab(right, &error));
  EXPECT_EQ(sim.grasps().size(), 2u);
  for (int frame = 0; frame < 50; ++frame) sim.advanceFrame();
  const double left_y = sim.state().positions_m(1, left.particle);
  const double right_y = sim.state().positions_m(1, right.particle);
  EXPECT_GT(right_y, left_y + 0.005) << "the extra force acts on its own grasp only";
  EXPECT_TRUE(sim.release(1));
  EXPECT_EQ(sim.grasps().size(), 1u);
  EXPECT_EQ(sim.grasps()[0].id, 2u);
}

TEST(Grasp, InvalidRequestsAreRefusedAndChangeNothing) {
  Simulation sim(SceneOptions{});
  GraspRequest bad;
  bad.particle = sim.grid().particleCount();
  std::string error;
  EXPECT_FALSE(sim.grab(bad, &error));
  EXPECT_NE(error.find("particle"), std::string::npos) << error;
  bad.particle = 0;
  bad.target_m = Eigen::Vector3d(std::nan(""), 0, 0);
  EXPECT_FALSE(sim.grab(bad, &error));
  EXPECT_NE(error.find("grasp target (nan, 0, 0) m: must be finite"), std::string::npos) << error;
  EXPECT_TRUE(sim.grasps().empty());
}

TEST(Grasp, AForceOfAtMostKMaxGraspForceIsTakenAndOneOverItRefused) {
  // The README and both checks (a new GRAB, a restored grasp) say "at most": 10,000 N exactly is taken.
  Simulation sim(SceneOptions{});
  GraspRequest request;
  request.particle = 0;
  request.target_m = sim.state().positions_m.col(0);
  request.extra_force_N = Eigen::Vector3d(0.0, Simulation::kMaxGraspForce_N, 0.0);
  std::string error;
  EXPECT_TRUE(sim.grab(request, &error)) << error;
  request.id = 1;
  request.extra_force_N.y() = std::nextafter(Simulation::kMaxGraspForce_N, 2.0 * Simulation::kMaxGraspForce_N);
  EXPECT_FALSE(sim.grab(request, &error));
  EXPECT_NE(error.find("grasp force (0, 10000"), std::string::npos) << error;
  EXPECT_NE(error.find("must be finite and at most 10000"), std::string::npos) << error;
  EXPECT_EQ(sim.grasps().size(), 1u);
}

TEST(Grasp, AReleasedPinIsHookedAgainWhereItWasLetGo) {
  // Paper: pins move only when grasped or driven. Carry the top-left corner 20 cm towards +y, let go.
  SceneOptions o;
  o.rows = 8;
  o.cols = 8;
  Simulation sim(o);
  const int corner = sim.grid().index(0, 0);
  GraspRequest hand;
  hand.id = 7;
  hand.particle = corner;
  hand.stiffness_N_per_m = 200.0;
  hand.target_m = sim.state().positions_m.col(corner) + Eigen::Vector3d(0.0, 0.2, 0.0);
  std::string error;
  ASSERT_TRUE(sim.grab(hand, &error)) << error;
  for (int frame = 0; frame < 100; ++frame) sim.advanceFrame();
  EXPECT_GT(sim.state().positions_m(1, corner), 0.15) << "the hand did not carry the pin";
  ASSERT_TRUE(sim.release(hand.id));
  const Eigen::Vector3d let_go = sim.state().positions_m.col(corner);
  for (int frame = 0; frame < 100; ++frame) {
    sim.advanceFrame();
    EXPECT_EQ(sim.state().positions_m.col(corner), let_go) << "frame " << frame;
    EXPECT_TRUE(sim.state().velocities_m_per_s.col(corner).isZero());
  }
  sim.reset();
  EXPECT_EQ(sim.state().positions_m.col(corner), sim.grid().rest_positions_m.col(corner)) << "reset re-hooks at rest";
}

TEST(Grasp, AtMostKMaxGraspsAreHeldAtOnce) {
  Simulation sim(SceneOptions{});
  std::string error;
  GraspRequest request;
  for (std::uint32_t id = 0; id < Simulation::kMaxGrasps; ++id) {
    request.id = id;
    request.particle = static_cast<int>(id);
    ASSERT_TRUE(sim.grab(request, &error)) << error;
  }
  request.id = 1000;
  EXPECT_FALSE(sim.grab(request, &error));
  EXPECT_NE(error.find("release one"), std::string::npos) << error;
  request.id = 3;  // an existing id still drags
  request.target_m = Eigen::Vector3d(0, 1, 1);
  EXPECT_TRUE(sim.grab(request, &error)) << error;
  ASSERT_TRUE(sim.release(3));
  request.id = 1000;
  EXPECT_TRUE(sim.grab(request, &error)) << error;
  EXPECT_EQ(sim.grasps().size(), Simulation::kMaxGrasps);
}

TEST(Pins, MovingPinsFollowTheirSinusoidAndFixedPinsStayPut) {
  SceneOptions o;
  o.rows = 6;
  o.cols = 6;
  o.pins = {"top_edge"};  // a curtain rail
  o.pin_motion_amplitude_m = Eigen::Vector3d(0.2, 0, 0);
  o.pin_motion_period_s = 2.0;
  Simulation sim(o);
  for (int frame = 0; frame < 30; ++frame) {
    sim.advanceFrame();
    const double t = sim.state().time_s;
    const double offset = 0.2 * std::sin(kTwoPi * t / 2.0);
    for (int i : sim.pinnedParticles()) {
      EXPECT_NEAR(sim.state().positions_m(0, i), sim.grid().rest_positions_m(0, i) + offset, 1e-12);
      EXPECT_NEAR(sim.state().positions_m(2, i), sim.grid().rest_positions_m(2, i), 1e-12);
    }
  }
  // The cloth below follows the rail: after half a period the bottom edge has moved along +x.
  const int bottom = sim.grid().index(5, 3);
  EXPECT_GT(std::abs(sim.state().positions_m(0, bottom) - sim.grid().rest_positions_m(0, bottom)), 0.02);
}

}  // namespace
}  // namespace cloth_sim::core
