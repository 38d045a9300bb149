// The standalone force model: its stencil kernels against the edge-list reference, its differential
// against finite differences, and its constraints.
#include "cloth_sim/core/force_model.h"
#include "cloth_sim/core/simulation.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <random>

namespace cloth_sim::core {
namespace {

/// A rows x cols cloth with every force but springs switched off, so forces are the springs' alone.
SceneOptions springsOnly(int rows, int cols) {
  SceneOptions o = test::freeCloth(rows, cols);
  o.air_damping_N_s_per_m = 0.0;
  return o;
}


Eigen::Matrix3Xd edgeListSpringForces(const Simulation& sim, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& v) {
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, x.cols());
  for (int k = 0; k < kSpringKindCount; ++k) {
    if (sim.options().springs[k].enabled) {
      accumulateSpringForces(sim.grid().springs[k], sim.options().springs[k], x, v, forces);
    }
  }
  return forces;
}

TEST(StencilKernels, GiveTheEdgeListKernelsForcesToRoundingOnEveryGridShape) {
  // Small, tall, wide, and large enough for threads (4096 particles and up).
  for (const auto& [rows, cols] : std::vector<std::pair<int, int>>{{2, 2}, {3, 7}, {9, 4}, {20, 20}, {70, 65}}) {
    Simulation sim(springsOnly(rows, cols));
    Eigen::Matrix3Xd x, v, stencil;
    test::perturb(sim.grid(), 17u + rows, &x, &v);
    sim.forceModel().forces(x, v, 0.0, stencil);
    const Eigen::Matrix3Xd reference = edgeListSpringForces(sim, x, v);
    const double scale = reference.cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0);
    EXPECT_LT((stencil - reference).cwiseAbs().maxCoeff(), 1e-12 * scale) << rows << "x" << cols;
  }
}

TEST(StencilKernels, TwoThreadsGiveTheSameBitsAsOne) {
  // Bands of rows recompute the springs that cross into them instead of sharing sums, so the thread
  // count changes no bit of the forces, the differential or a whole implicit run.
  SceneOptions one = springsOnly(70, 65);
  one.gravity_m_per_s2 = Eigen::Vector3d(0.0, 0.0, -9.81);
  one.pins = {"top_left", "top_right"};
  SceneOptions two = one;
  two.threads = 2;
  Simulation a(one);
  Simulation b(two);
  ASSERT_EQ(a.forceModel().threads(), 1);
  ASSERT_EQ(b.forceModel().threads(), 2);
  Eigen::Matrix3Xd x, v, fa, fb;
  test::perturb(a.grid(), 23u, &x, &v);
  a.forceModel().forces(x, v, 0.0, fa);
  b.forceModel().forces(x, v, 0.0, fb);
  EXPECT_TRUE(fa == fb);
  a.forceModel().linearize(x, v, 0.0);
  b.forceModel().linearize(x, v, 0.0);
  a.forceModel().systemProduct(0.02, v, fa);
  b.forceModel().systemProduct(0.02, v, fb);
  EXPECT_TRUE(fa == fb);
  for (int frame = 0; frame < 5; ++frame) {
    a.advanceFrame();
    b.advanceFrame();
  }
  EXPECT_TRUE(a.state().positions_m == b.state().positions_m);
  EXPECT_TRUE(a.state().velocities_m_per_s == b.state().velocities_m_per_s);
}

TEST(StencilKernels, ASwitchedOffSpringKindExertsNothing) {
  SceneOptions o = springsOnly(8, 8);
  o.springs[static_cast<int>(SpringKind::kShear)].enabled = false;
  Simulation sim(o);
  Eigen::Matrix3Xd x, v, stencil;
  test::perturb(sim.grid(), 3u, &x, &v);
  sim.forceModel().forces(x, v, 0.0, stencil);
  const Eigen::Matrix3Xd reference = edgeListSpringForces(sim, x, v);
  EXPECT_LT((stencil - reference).cwiseAbs().maxCoeff(), 1e-12 * reference.cwiseAbs().maxCoeff());
}

TEST(ForceDifferential, MatchesCentralFiniteDifferencesOfTheForcesForStretchedSprings) {
  // Stretched everywhere (the definiteness fix only drops terms of compressed springs), with a grasp
  // and air damping, so every term of the differential is checked.
  SceneOptions o = test::freeCloth(6, 5);
  o.air_damping_N_s_per_m = 0.01;
  Simulation sim(o);
  GraspRequest hand;
  hand.particle = 7;
  hand.target_m = Eigen::Vector3d(0.2, 0.3, 1.0);
  std::string error;
  ASSERT_TRUE(sim.grab(hand, &error)) << error;
  const Eigen::Matrix3Xd x = 1.2 * sim.grid().rest_positions_m;  // every spring 20 % long
  Eigen::Matrix3Xd v, dx, dv;
  test::perturb(sim.grid(), 5u, &dx, &v);
  dx -= sim.grid().rest_positions_m;
  dv = Eigen::Matrix3Xd::Random(3, x.cols());
  ClothForceModel& model = sim.forceModel();
  model.linearize(x, v, 0.0);
  Eigen::Matrix3Xd analytic;
  model.forceDifferential(dx, dv, analytic);
  const double eps = 1e-6;
  Eigen::Matrix3Xd plus, minus;
  model.forces(x + eps * dx, v + eps * dv, 0.0, plus);
  model.forces(x - eps * dx, v - eps * dv, 0.0, minus);
  const Eigen::Matrix3Xd numeric = (plus - minus) / (2.0 * eps);
  // The spring damping's dependence on the direction (dF/dx of the damping term) is left out, as in
  // Baraff and Witkin: compare without velocities there.
  EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-2 * numeric.cwiseAbs().maxCoeff());
  model.linearize(x, Eigen::Matrix3Xd::Zero(3, x.cols()), 0.0);
  model.forces(x + eps * dx, eps * dv, 0.0, plus);
  model.forces(x - eps * dx, -eps * dv, 0.0, minus);
  model.forceDifferential(dx, dv, analytic);
  EXPECT_LT((analytic - (plus - minus) / (2.0 * eps)).cwiseAbs().maxCoeff(), 1e-6 * numeric.cwiseAbs().maxCoeff());
}

TEST(ForceDifferential, SystemProductAndItsDiagonalBlocksAgreeWithTheDifferential) {
  SceneOptions o = test::freeCloth(5, 6);
  o.air_damping_N_s_per_m = 0.02;
  Simulation sim(o);
  ClothForceModel& model = sim.forceModel();
  Eigen::Matrix3Xd x, v;
  test::perturb(sim.grid(), 11u, &x, &v);
  model.linearize(x, v, 0.0);
  const double h = 0.02;
  const Eigen::Matrix3Xd w = Eigen::Matrix3Xd::Random(3, x.cols());
  Eigen::Matrix3Xd product, differential;
  model.systemProduct(h, w, product);
  model.forceDifferential(h * h * w, h * w, differential);
  const Eigen::Matrix3Xd expected = w * sim.massPerParticle_kg().asDiagonal() - differential;
  EXPECT_LT((product - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
  // The diagonal block of particle i is the system matrix applied to unit vectors at i, read at i.
  Eigen::Matrix<double, 6, Eigen::Dynamic> blocks;
  model.systemDiagonalBlocks(h, blocks);
  for (int i : {0, 7, 29}) {
    Eigen::Matrix3d block;
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Matrix3Xd unit = Eigen::Matrix3Xd::Zero(3, x.cols());
      unit(axis, i) = 1.0;
      model.systemProduct(h, unit, product);
      block.col(axis) = product.col(i);
    }
    const Eigen::Matrix<double, 6, 1> b = blocks.col(i);
    Eigen::Matrix3d packed;
    packed << b[0], b[3], b[4], b[3], b[1], b[5], b[4], b[5], b[2];
    EXPECT_LT((packed - block).cwiseAbs().maxCoeff(), 1e-12 * block.cwiseAbs().maxCoeff()) << "particle " << i;
  }
}

TEST(ForceModel, AHookedPinIsConstrainedAndAGraspedPinIsFree) {
  SceneOptions o;  // hanging: two top corners pinned
  Simulation sim(o);
  const int corner = sim.pinnedParticles().front();
  EXPECT_EQ(sim.forceModel().inverseMass_per_kg()[corner], 0.0);
  EXPECT_GT(sim.forceModel().inverseMass_per_kg()[1], 0.0);
  GraspRequest hand;
  hand.particle = corner;
  hand.target_m = sim.state().positions_m.col(corner);
  std::string error;
  ASSERT_TRUE(sim.grab(hand, &error)) << error;
  EXPECT_GT(sim.forceModel().inverseMass_per_kg()[corner], 0.0) << "a grasped pin comes off its hook";
  ASSERT_TRUE(sim.release(hand.id));
  EXPECT_EQ(sim.forceModel().inverseMass_per_kg()[corner], 0.0) << "released, it hangs on a hook again";
}

}  // namespace
}  // namespace cloth_sim::core
