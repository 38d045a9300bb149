// Paper §4: the contact band, the collision response and penetration correction.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace cloth_sim::core {
namespace {

constexpr double kGravity_m_per_s2 = 9.81;

/// Four free particles (a 2 x 2 grid with every spring off): each one is an independent point mass.
SceneOptions freeParticles(const Eigen::Vector3d& origin_m, const Eigen::Vector3d& u_axis,
                           const Eigen::Vector3d& v_axis) {
  SceneOptions o = test::withSymplecticEuler(SceneOptions());
  o.rows = 2;
  o.cols = 2;
  o.width_m = 0.1;
  o.height_m = 0.1;
  o.origin_m = origin_m;
  o.u_axis = u_axis;
  o.v_axis = v_axis;
  o.pins.clear();
  for (SpringOptions& s : o.springs) s.enabled = false;
  o.air_damping_N_s_per_m = 0.0;
  return o;
}

/// One particle, one collider: runs resolveContacts on a single substep from start to end.
struct OneParticle {
  Eigen::Matrix3Xd previous = Eigen::Matrix3Xd::Zero(3, 1);
  Eigen::Matrix3Xd position = Eigen::Matrix3Xd::Zero(3, 1);
  Eigen::Matrix3Xd velocity = Eigen::Matrix3Xd::Zero(3, 1);
  Eigen::VectorXd inverse_mass = Eigen::VectorXd::Ones(1);
  ContactStats resolve(const ColliderSet& colliders, const ContactOptions& options, double t0_s = 0.0,
                       double t1_s = 0.001, const Eigen::Matrix3Xd* forces_N = nullptr) {
    return resolveContacts(colliders, options, t0_s, t1_s, inverse_mass, previous, position, velocity, forces_N);
  }
};

TEST(Contact, ParticleDroppedOnTheFloorReboundsToRestitutionSquaredOfItsHeight) {
  const double drop_height_m = 1.0;
  SceneOptions o = freeParticles({0, 0, drop_height_m}, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY());
  o.colliders.planes.push_back(PlaneCollider{});  // z = 0
  o.contact.restitution = 0.7;
  o.contact.friction = 0.0;
  Simulation sim(o);
  // Fall (0.45 s), then track the apex of the rebound until the particle comes down again.
  double apex_m = 0.0;
  bool bounced = false;
  for (int frame = 0; frame < 100; ++frame) {
    sim.advanceFrame();
    const double z = sim.state().positions_m(2, 0);
    const double vz = sim.state().velocities_m_per_s(2, 0);
    if (vz > 0.0) bounced = true;
    if (bounced) apex_m = std::max(apex_m, z);
  }
  const double expected_m = o.contact.restitution * o.contact.restitution * drop_height_m;
  RecordProperty("apex_m", std::to_string(apex_m));
  EXPECT_NEAR(apex_m, expected_m, 0.02 * expected_m) << "apex " << apex_m << " m, e^2 h = " << expected_m << " m";
}

TEST(Contact, ParticleInTheBandMovingAwayIsLeftAlone) {
  const ContactOptions options;  // depth 2 mm
  ColliderSet plane_only;
  plane_only.planes.push_back(PlaneCollider{});
  ColliderSet sphere_only;
  sphere_only.spheres.push_back(SphereCollider{});  // r = 0.1 at the origin
  sphere_only.spheres[0].center_m = Eigen::Vector3d(0, 0, -0.1);  // top of the sphere at z = 0
  ColliderSet box_only;
  box_only.boxes.push_back(BoxCollider{Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 0)});  // top at z = 0
  for (const ColliderSet* colliders : {&plane_only, &sphere_only, &box_only}) {
    // Both halves of the band: just above and just below the surface, moving up (away).
    for (double height_m : {0.5 * options.depth_m, -0.5 * options.depth_m}) {
      OneParticle p;
      p.previous.col(0) = Eigen::Vector3d(0, 0, height_m - 0.0001);
      p.position.col(0) = Eigen::Vector3d(0, 0, height_m);
      p.velocity.col(0) = Eigen::Vector3d(0.3, 0, 0.1);
      const Eigen::Matrix3Xd position_before = p.position;
      const Eigen::Matrix3Xd velocity_before = p.velocity;
      const ContactStats stats = p.resolve(*colliders, options);
      EXPECT_EQ(p.position, position_before) << "height " << height_m;
      EXPECT_EQ(p.velocity, velocity_before) << "height " << height_m;
      EXPECT_EQ(stats.band_collisions + stats.penetrations + stats.swept_hits, 0);
    }
  }
}

TEST(Contact, ParticleInTheBandApproachingGetsTheResponse) {
  ContactOptions options;
  options.restitution = 0.5;
  options.friction = 0.2;
  ColliderSet plane_only;
  plane_only.planes.push_back(PlaneCollider{});
  OneParticle p;
  p.previous.col(0) = Eigen::Vector3d(0, 0, 0.0015);
  p.position.col(0) = Eigen::Vector3d(0, 0, 0.001);
  p.velocity.col(0) = Eigen::Vector3d(1.0, 0, -2.0);
  const ContactStats stats = p.resolve(plane_only, options);
  EXPECT_EQ(stats.band_collisions, 1);
  // Normal: -2 -> +e * 2 = 1. Tangential: 1 - mu (1 + e) 2 = 1 - 0.2 * 3 = 0.4 (Coulomb).
  EXPECT_NEAR(p.velocity(2, 0), 1.0, 1e-12);
  EXPECT_NEAR(p.velocity(0, 0), 0.4, 1e-12);
  EXPECT_EQ(p.position(2, 0), 0.001) << "above the surface: only the velocity changes";
}

TEST(Contact, PenetratedParticleIsProjectedBackOntoTheSurface) {
  const ContactOptions options;
  ColliderSet colliders;
  colliders.planes.push_back(PlaneCollider{});
  colliders.boxes.push_back(BoxCollider{Eigen::Vector3d(2, -1, -1), Eigen::Vector3d(3, 1, 0.5)});
  colliders.spheres.push_back(SphereCollider{});
  colliders.spheres[0].center_m = Eigen::Vector3d(-2, 0, 0.5);
  colliders.spheres[0].radius_m = 0.3;
  const Eigen::Vector3d deep_points[3] = {{0, 0, -0.05}, {2.5, 0, 0.45}, {-2, 0.05, 0.6}};
  for (const Eigen::Vector3d& point : deep_points) {
    OneParticle p;
    p.previous.col(0) = point;  // already inside at the start: a penetration, not a sweep
    p.position.col(0) = point;
    p.velocity.col(0) = Eigen::Vector3d(0, 0, -1);
    const ContactStats stats = p.resolve(colliders, options);
    EXPECT_EQ(stats.penetrations, 1) << point.transpose();
    EXPECT_LE(maxPenetration(colliders, 0.001, p.position), 1e-12) << point.transpose();
  }
}

TEST(Contact, StaticFrictionPutsAParticleItHoldsBackWhereItStartedOnEveryShape) {
  // Each shape's top lies at z = 0.5: a plane, a box's top face, a sphere's north pole. A particle resting
  // there ends a 1 ms substep 1 mm inside (1 m/s into the surface: with mu 0.5 the response stops up to
  // 0.5 m/s along it) and `slide_m` along it, pushed along the surface by `force_N` (inverse mass 1).
  ColliderSet shapes[3];
  shapes[0].planes.push_back(PlaneCollider{Eigen::Vector3d::UnitZ(), -0.5});  // n . x + d = 0
  shapes[1].boxes.push_back(BoxCollider{Eigen::Vector3d(-1, -1, 0.0), Eigen::Vector3d(1, 1, 0.5)});
  shapes[2].spheres.push_back(SphereCollider{});
  shapes[2].spheres[0].radius_m = 0.5;
  ContactOptions options;
  options.friction = 0.5;
  struct Case {
    double slide_m;
    double force_N;  ///< along the slide; F h / m against mu x 1 m/s: held below 500 N
    bool with_forces;
    double expected_m;  ///< where it ends along the slide
    const char* what;
  };
  const Case cases[] = {
      {0.4e-3, 100.0, true, 0.0, "held: taken back"},
      {0.4e-3, 1000.0, true, 0.4e-3, "stopped, but pulled harder than friction holds: the slide stays"},
      {0.4e-3, 100.0, false, 0.4e-3, "no forces given: the velocity response alone"},
      {2e-3, 0.0, true, 2e-3, "sliding at 2 m/s: kinetic friction, the slide stays"},
  };
  for (int shape = 0; shape < 3; ++shape) {
    for (const Case& c : cases) {
      OneParticle p;
      p.previous.col(0) = Eigen::Vector3d(0, 0, 0.5);
      p.position.col(0) = Eigen::Vector3d(c.slide_m, 0, 0.499);
      p.velocity.col(0) = Eigen::Vector3d(c.slide_m / 0.001, 0, -1.0);
      const Eigen::Matrix3Xd forces = Eigen::Vector3d(c.force_N, 0, -9.81);
      p.resolve(shapes[shape], options, 0.0, 0.001, c.with_forces ? &forces : nullptr);
      // The sphere's surface curves away under the slide: its push is along the end point's radius.
      const double tolerance_m = shape == 2 ? 1e-5 : 1e-12;
      EXPECT_NEAR(p.position(0, 0), c.expected_m, tolerance_m) << "shape " << shape << ": " << c.what;
      EXPECT_NEAR(p.position(2, 0), 0.5, tolerance_m) << "shape " << shape << ": back on the surface";
    }
  }
}

TEST(Contact, FrictionHoldsOnASlopeShallowerThanAtanMuAndNotOnASteeperOne) {
  const double mu = 0.5;  // atan(0.5) = 26.6 degrees
  const double duration_s = 2.0;
  for (double slope_deg : {20.0, 35.0}) {
    const double theta = slope_deg * kPi / 180.0;
    const Eigen::Vector3d downhill(std::cos(theta), 0.0, -std::sin(theta));
    SceneOptions o = freeParticles(Eigen::Vector3d(0, 0, 0), downhill, Eigen::Vector3d::UnitY());
    o.colliders.planes.push_back(PlaneCollider{Eigen::Vector3d(std::sin(theta), 0.0, std::cos(theta)), 0.0});
    o.contact.friction = mu;
    Simulation sim(o);
    const Eigen::Vector3d start = sim.state().positions_m.col(0);
    for (int frame = 0; frame < static_cast<int>(duration_s * o.frame_rate_hz); ++frame) sim.advanceFrame();
    const double slid_m = (sim.state().positions_m.col(0) - start).dot(downhill);
    const double speed = sim.state().velocities_m_per_s.col(0).norm();
    const double coulomb_m =
        0.5 * kGravity_m_per_s2 * (std::sin(theta) - mu * std::cos(theta)) * duration_s * duration_s;
    if (std::tan(theta) < mu) {
      // Stuck: the velocity is zeroed at every contact, and the step's own slide along the slope is taken
      // back. Without that it crept by g sin(theta) h^2 a substep: 3.4 mm over 2 s here.
      EXPECT_EQ(speed, 0.0) << slope_deg << " deg";
      EXPECT_LT(std::abs(slid_m), 1e-12) << slope_deg << " deg: static friction holds it where it lies";
    } else {
      EXPECT_NEAR(slid_m, coulomb_m, 0.02 * coulomb_m) << slope_deg << " deg: slides with g (sin - mu cos)";
      EXPECT_GT(speed, 1.0);
    }
  }
}

/// Runs a scene two substeps per advanceFrame at the same step (frame rate 1000 Hz, the most validation
/// allows), so the invariant is checked after every other step; resolveContacts is the last thing a
/// substep does, and the kernel tests above check it after single steps.
void expectNothingInsideAfterEveryStep(SceneOptions o, int steps) {
  // The scene's own step: implicit Euler's `auto` takes one step per frame.
  const double step_s = o.autoSubsteps() ? o.frameDuration_s() : o.substep_s();
  o.substeps = 2;
  o.frame_rate_hz = 1.0 / (o.substeps * step_s);
  steps /= o.substeps;
  Simulation sim(o);
  double worst_m = 0.0;
  for (int step = 0; step < steps; ++step) {
    ASSERT_TRUE(sim.advanceFrame().stable);
    worst_m = std::max(worst_m, maxPenetration(o.colliders, sim.state().time_s, sim.state().positions_m));
  }
  ::testing::Test::RecordProperty(o.name + "_worst_penetration_m", std::to_string(worst_m));
  EXPECT_LE(worst_m, o.contact.depth_m) << o.name << ": a particle ended a step beyond the contact band";
}

TEST(Contact, NoParticleEndsAnyStepInsideAColliderInTheColliderScenes) {
  for (const char* name : {"tablecloth", "ball", "drop"}) {
    SCOPED_TRACE(name);
    expectNothingInsideAfterEveryStep(test::loadBuiltinScene(name), 100);  // 2 s at one step per frame
  }
}

TEST(Contact, SweepCatchesAParticleThatWouldCrossAThinBoxInOneStep) {
  ColliderSet colliders;
  colliders.boxes.push_back(BoxCollider{Eigen::Vector3d(-1, -1, 0.0), Eigen::Vector3d(1, 1, 0.01)});  // 1 cm slab
  OneParticle p;
  p.previous.col(0) = Eigen::Vector3d(0, 0, 0.1);
  p.position.col(0) = Eigen::Vector3d(0, 0, -0.1);  // jumped clean through
  p.velocity.col(0) = Eigen::Vector3d(0, 0, -20.0);
  const ContactStats stats = p.resolve(colliders, ContactOptions{});
  EXPECT_EQ(stats.swept_hits, 1);
  EXPECT_NEAR(p.position(2, 0), 0.01, 1e-12) << "stopped on the top face where it entered";
  EXPECT_GE(p.velocity(2, 0), 0.0);

  // The same from the band: resting 0.1 mm under the top face (rounding), then thrown through.
  OneParticle resting;
  resting.previous.col(0) = Eigen::Vector3d(0, 0, 0.01 - 1e-4);
  resting.position.col(0) = Eigen::Vector3d(0, 0, -0.1);
  resting.velocity.col(0) = Eigen::Vector3d(0, 0, -20.0);
  const ContactStats from_band = resting.resolve(colliders, ContactOptions{});
  EXPECT_EQ(from_band.swept_hits, 1) << "the crossing must be counted";
  EXPECT_NEAR(resting.position(2, 0), 0.01, 1e-12) << "back on the top face, not out of the bottom";
}

TEST(Contact, SweepCatchesAParticleRestingOnAFastSphereThatWouldPassIt) {
  // A particle lies on a sphere's surface, just inside the band after rounding. In one substep the sphere
  // moves further than its diameter: seen from the sphere the particle goes through it and out the back.
  const ContactOptions options;
  SphereCollider sphere;
  sphere.radius_m = 0.05;
  sphere.center_m = Eigen::Vector3d(0, -0.05, 0);
  sphere.velocity_m_per_s = Eigen::Vector3d(0, 10.0, 0);
  ColliderSet colliders;
  colliders.spheres.push_back(sphere);
  const double step_s = 0.02;  // the sphere moves 0.2 m = two diameters
  OneParticle p;
  p.previous.col(0) = Eigen::Vector3d(0, -1e-4, 0);  // 0.1 mm inside the surface: in the band
  p.position.col(0) = p.previous.col(0);           // the cloth held it still
  const ContactStats stats = p.resolve(colliders, options, 0.0, step_s);
  const Eigen::Vector3d center1 = sphere.centerAt(step_s);
  EXPECT_EQ(stats.swept_hits + stats.penetrations, 1) << "the crossing must be counted";
  EXPECT_GE(p.position(1, 0), center1.y()) << "the particle must end in front of the sphere, not behind it";
  EXPECT_NEAR((p.position.col(0) - center1).norm(), sphere.radius_m, 1e-9);
  EXPECT_GE(p.velocity(1, 0), 10.0 - 1e-9) << "and be carried along at the sphere's speed";
}

TEST(Contact, TenMetrePerSecondSphereThroughA64x64ClothIsCaughtAndPushesIt) {
  // A limp 64 x 64 cloth (soft springs, no gravity, so a coarse step is stable) and a 5 cm sphere at
  // 10 m/s: with 4 substeps per frame the sphere moves 5 cm = one radius per substep, more than the
  // 1.6 cm particle spacing. Every particle on its path must be caught and carried in front of it.
  SceneOptions o;
  o.name = "fast_sphere";
  o.rows = 64;
  o.cols = 64;
  o.gravity_m_per_s2.setZero();
  o.springs[0] = {true, 2.0, 0.0};
  o.springs[1] = {true, 0.5, 0.0};
  o.springs[2] = {true, 0.1, 0.0};
  o.air_damping_N_s_per_m = 0.0;
  o.integrator = IntegratorKind::kSymplecticEuler;
  o.substeps = 4;
  SphereCollider sphere;
  sphere.radius_m = 0.05;
  sphere.center_m = Eigen::Vector3d(0.0, -0.3, 1.0);  // the cloth's centre is at (0, 0, 1)
  sphere.velocity_m_per_s = Eigen::Vector3d(0.0, 10.0, 0.0);
  o.colliders.spheres.push_back(sphere);
  o.contact.restitution = 0.0;
  o.contact.friction = 0.5;
  Simulation sim(o);
  ContactStats caught;
  double worst_m = 0.0;
  for (int frame = 0; frame < 3; ++frame) {  // 0.06 s: the sphere ends 0.3 m beyond the cloth's plane
    const FrameReport report = sim.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    caught += report.contacts;
    worst_m = std::max(worst_m, maxPenetration(o.colliders, sim.state().time_s, sim.state().positions_m));
  }
  const Eigen::Vector3d center = sim.sphereCenters()[0];
  ASSERT_GT(center.y(), 0.25);
  int on_path = 0;
  int behind = 0;
  double pushed_m = 0.0;
  for (int i = 0; i < sim.grid().particleCount(); ++i) {
    const Eigen::Vector3d x = sim.state().positions_m.col(i);
    const Eigen::Vector3d rest = sim.grid().rest_positions_m.col(i);
    if ((Eigen::Vector2d(rest.x(), rest.z()) - Eigen::Vector2d(center.x(), center.z())).norm() >
        0.5 * sphere.radius_m) {
      continue;  // not on the sphere's path
    }
    ++on_path;
    if (x.y() < center.y()) ++behind;
    pushed_m = std::max(pushed_m, x.y());
  }
  RecordProperty("caught_particles", caught.swept_hits + caught.band_collisions + caught.penetrations);
  EXPECT_GT(on_path, 0);
  EXPECT_EQ(behind, 0) << on_path << " particles on the path, " << behind << " left behind the sphere";
  EXPECT_GT(caught.swept_hits + caught.penetrations + caught.band_collisions, 0);
  EXPECT_GT(pushed_m, 0.25) << "the cloth is pushed along";
  EXPECT_LE(worst_m, o.contact.depth_m);
}

TEST(Contact, TheColliderHoldingParticlesIsNamedWithHowManyAndHowDeep) {
  // Three particles: one on the floor, one 5 cm inside a ball, one 1 mm under the floor (inside the
  // 2 mm contact band: a contact, not held).
  Eigen::Matrix3Xd positions(3, 3);
  positions.col(0) << 0.0, 0.0, 0.0;
  positions.col(1) << 0.0, 0.0, 1.05;
  positions.col(2) << 2.0, 0.0, -0.001;
  ColliderSet colliders;
  colliders.planes.push_back(PlaneCollider{});
  SphereCollider ball;
  ball.center_m = Eigen::Vector3d(0.0, 0.0, 1.0);
  ball.radius_m = 0.1;
  colliders.spheres.push_back(ball);
  const double band_m = ContactOptions().depth_m;
  ASSERT_EQ(band_m, 0.002);
  EXPECT_EQ(colliderHoldingParticles(colliders, band_m, 0.0, positions, {}),
            "sphere 0 (centre (0, 0, 1) m, radius 0.1 m) holds 1 particle, up to 0.05 m deep");
  // Where it is at the time asked (a sphere moving at 1 m/s along x is clear of it after 0.2 s).
  colliders.spheres[0].velocity_m_per_s = Eigen::Vector3d::UnitX();
  EXPECT_EQ(colliderHoldingParticles(colliders, band_m, 0.2, positions, {}), "");
  // Planes first; a particle an outline removed is not the cloth's.
  positions.col(2).z() = -0.01;
  EXPECT_EQ(colliderHoldingParticles(colliders, band_m, 0.0, positions, {}),
            "plane 0 (normal (0, 0, 1), offset 0 m) holds 1 particle, up to 0.01 m deep");
  EXPECT_EQ(colliderHoldingParticles(colliders, band_m, 0.2, positions, {1, 1, 0}), "");
  ColliderSet table;
  table.boxes.push_back(BoxCollider{Eigen::Vector3d(-1.0, -1.0, 0.9), Eigen::Vector3d(1.0, 1.0, 1.1)});
  EXPECT_EQ(colliderHoldingParticles(table, band_m, 0.0, positions, {}),
            "box 0 (min (-1, -1, 0.9) m, max (1, 1, 1.1) m) holds 1 particle, up to 0.05 m deep");
}

TEST(Contact, AClothThatStartsInsideAColliderIsRefusedWhereItIsBuilt) {
  // Before, such a scene ran: its first frame pushed the particles out faster than anything in the scene
  // moves, the guard rolled it back, and the recovery's reset started it inside again, frame 0 for good.
  SceneOptions options = test::loadBuiltinScene("hanging");
  options.rows = 20;
  options.cols = 20;
  SphereCollider ball;
  ball.center_m = Eigen::Vector3d(0.0, 0.0, 1.0);
  ball.radius_m = 0.1;
  options.colliders.spheres = {ball};
  try {
    Simulation simulation(options);
    ADD_FAILURE() << "a cloth through a ball was built";
  } catch (const std::invalid_argument& refused) {
    const std::string message = refused.what();
    EXPECT_NE(message.find("the cloth starts inside a collider: sphere 0"), std::string::npos) << message;
    EXPECT_NE(message.find("12 particles"), std::string::npos) << message;
  }
  // Touching it from outside (within the contact band) is a contact: built, and it runs.
  options.colliders.spheres[0].center_m.y() = ball.radius_m;
  Simulation touching(options);
  EXPECT_TRUE(touching.advanceFrame().stable);
  // Nor may a retune or a restore bring the ball in: the recovery's reset would start the cloth there.
  SceneOptions through = touching.options();
  through.colliders.spheres[0].center_m.y() = 0.0;
  std::string error;
  EXPECT_FALSE(touching.retune(through, &error));
  EXPECT_NE(error.find("sphere 0"), std::string::npos) << error;
  SimulationSnapshot snapshot = touching.snapshot();
  snapshot.options = through;
  EXPECT_FALSE(touching.restore(snapshot, &error));
  EXPECT_NE(error.find("starts inside a collider"), std::string::npos) << error;
}

TEST(Contact, APinHeldInsideAColliderIsAClampNotAClothInsideIt) {
  // Contacts leave pinned particles alone, so a box around a pin (a clamp, a curtain rail) was always fine.
  SceneOptions options = test::loadBuiltinScene("hanging");
  options.rows = 20;
  options.cols = 20;
  Simulation probe(options);
  const Eigen::Vector3d pin_m = probe.state().positions_m.col(0);
  const Eigen::Vector3d half_m = Eigen::Vector3d::Constant(0.01);
  options.colliders.boxes = {BoxCollider{pin_m - half_m, pin_m + half_m}};
  Simulation clamped(options);
  for (int frame = 0; frame < 20; ++frame) ASSERT_TRUE(clamped.advanceFrame().stable) << "frame " << frame;
}

}  // namespace
}  // namespace cloth_sim::core
