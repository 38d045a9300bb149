// Foundation claims of the core: springs, gravity and pins behave as hand calculations say.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cloth_sim::core {
namespace {

/// Forces only from the given spring kinds: no gravity, damping, pins or colliders.
SceneOptions springOnlyOptions(int rows, int cols) {
  SceneOptions o = test::freeCloth(rows, cols);
  o.air_damping_N_s_per_m = 0.0;
  for (SpringOptions& s : o.springs) s.damping_N_s_per_m = 0.0;
  return o;
}

TEST(Springs, TwoParticlesOscillateAtTheAnalyticFrequency) {
  // Two free particles of mass m joined by one spring oscillate with omega = sqrt(2 k / m)
  // (reduced mass m / 2). A 2 x 1 grid is not allowed, so use 2 x 2 with shear and bend off and the
  // cloth stretched along u only: each row is an independent two-body system, and the two columns
  // move together so the vertical springs stay at rest length.
  SceneOptions o = springOnlyOptions(2, 2);
  o.springs[static_cast<int>(SpringKind::kShear)].enabled = false;
  o.springs[static_cast<int>(SpringKind::kBend)].enabled = false;
  const double k = o.springs[0].stiffness_N_per_m;
  o.integrator = IntegratorKind::kRK4;
  o.substeps = 200;
  Simulation sim(o);
  const double m = sim.massPerParticle_kg()[0];
  const double omega = std::sqrt(2.0 * k / m);
  const double amplitude_m = 0.01;  // each end pulled out by this much
  ClothState start = sim.state();
  for (int r = 0; r < 2; ++r) {
    start.positions_m(0, sim.grid().index(r, 0)) -= amplitude_m;
    start.positions_m(0, sim.grid().index(r, 1)) += amplitude_m;
  }
  std::string error;
  ASSERT_TRUE(sim.restoreState(start, &error)) << error;
  const double width0 = sim.options().width_m;
  double max_error_m = 0.0;
  for (int frame = 0; frame < 50; ++frame) {
    sim.advanceFrame();
    const ClothState& s = sim.state();
    const double stretch = s.positions_m(0, 1) - s.positions_m(0, 0) - width0;
    const double expected = 2.0 * amplitude_m * std::cos(omega * s.time_s);
    max_error_m = std::max(max_error_m, std::abs(stretch - expected));
  }
  // The period 2 pi / omega is about 50 ms: 50 frames hold 20 periods, so a frequency error of a tenth
  // of a percent would already show as a phase error of 0.13 rad, far above the bound.
  EXPECT_LT(max_error_m, 1e-3 * amplitude_m) << "omega = " << omega << " rad/s, period " << 2 * kPi / omega << " s";
}

TEST(Springs, HangingChainSettlesAtTheHandComputedStretch) {
  // A vertical 2-column cloth with only vertical structural springs switched on is two chains. Pin the
  // top row; spring j (counted from the top) carries the weight of the (rows - 1 - j) particles below
  // it, so its stretch is (rows - 1 - j) m g / k. Heavy damping makes it settle.
  SceneOptions o;
  o.rows = 6;
  o.cols = 2;
  o.width_m = 0.5;  // wide: the horizontal springs then see no load, the chains hang straight
  o.height_m = 0.5;
  o.pins = {"top_edge"};
  o.springs[static_cast<int>(SpringKind::kShear)].enabled = false;
  o.springs[static_cast<int>(SpringKind::kBend)].enabled = false;
  o.springs[0].stiffness_N_per_m = 200.0;
  o.springs[0].damping_N_s_per_m = 0.5;
  o.air_damping_N_s_per_m = 0.01;
  o.substeps = 20;
  Simulation sim(o);
  for (int frame = 0; frame < 1500; ++frame) sim.advanceFrame();
  const double m = sim.massPerParticle_kg()[0];
  const double k = o.springs[0].stiffness_N_per_m;
  const double g = 9.81;
  const double rest_m = o.height_m / (o.rows - 1);
  for (int j = 0; j + 1 < o.rows; ++j) {
    const double length_m = sim.state().positions_m(2, sim.grid().index(j, 0)) -
                            sim.state().positions_m(2, sim.grid().index(j + 1, 0));
    const double expected_stretch_m = (o.rows - 1 - j) * m * g / k;
    EXPECT_NEAR(length_m - rest_m, expected_stretch_m, 1e-3 * expected_stretch_m + 1e-9) << "spring " << j;
  }
}

TEST(Springs, MomentumIsConservedWithSpringsOnly) {
  SceneOptions o = springOnlyOptions(6, 6);
  for (SpringOptions& s : o.springs) s.damping_N_s_per_m = 0.1;  // internal damping conserves momentum too
  Simulation sim(o);
  ClothState kicked = sim.state();
  for (int i = 0; i < kicked.particleCount(); ++i) {
    kicked.velocities_m_per_s.col(i) = Eigen::Vector3d(std::sin(i * 1.3), std::cos(i * 0.7), std::sin(i * 2.1));
    kicked.positions_m.col(i) += 0.01 * Eigen::Vector3d(std::cos(i * 0.9), std::sin(i * 1.7), std::cos(i * 0.4));
  }
  std::string error;
  ASSERT_TRUE(sim.restoreState(kicked, &error));
  const auto momentum = [&] { return Eigen::Vector3d(sim.state().velocities_m_per_s * sim.massPerParticle_kg()); };
  const Eigen::Vector3d before = momentum();
  ASSERT_GT(before.norm(), 1e-3);
  for (int frame = 0; frame < 100; ++frame) ASSERT_TRUE(sim.advanceFrame().stable);
  EXPECT_LT((momentum() - before).norm(), 1e-9 * (1.0 + before.norm()));
}

TEST(Springs, PinnedParticlesNeverMove) {
  SceneOptions o;  // the hanging scene's defaults: two top corners pinned, gravity on
  o.rows = 8;
  o.cols = 8;
  Simulation sim(o);
  const std::vector<int> pins = sim.pinnedParticles();
  ASSERT_EQ(pins.size(), 2u);
  const Eigen::Matrix3Xd start = sim.state().positions_m;
  for (int frame = 0; frame < 200; ++frame) {
    sim.advanceFrame();
    for (int i : pins) {
      EXPECT_EQ(sim.state().positions_m.col(i), start.col(i)) << "pin " << i << " frame " << frame;
      EXPECT_TRUE(sim.state().velocities_m_per_s.col(i).isZero());
    }
  }
  // And the rest did move: the top edge sags (stretches) between the two pins.
  const int top_middle = sim.grid().index(0, 4);
  EXPECT_LT(sim.state().positions_m(2, top_middle), start(2, top_middle) - 0.002);
}

}  // namespace
}  // namespace cloth_sim::core
