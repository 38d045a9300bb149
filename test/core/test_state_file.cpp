// Save and restore: Simulation::snapshot/restore check everything and continue bit for bit; the scene
// writer (sceneYaml) reads back every field exactly; the state file round-trips bit-exactly and refuses
// every kind of damage with a reason (doc/STATE_FILE.md, doc/RELIABILITY.md "Save and restore").
#include "cloth_sim/io/state_file.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <set>

namespace cloth_sim::core {
namespace {

namespace fs = std::filesystem;
using test::loadBuiltinScene;

constexpr IntegratorKind kAllIntegrators[] = {IntegratorKind::kForwardEuler, IntegratorKind::kSymplecticEuler,
                                              IntegratorKind::kMidpoint, IntegratorKind::kRK4,
                                              IntegratorKind::kImplicitEuler};

// ---- Bitwise comparisons ---------------------------------------------------------------------------

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

bool sameMatrixBits(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  // memcmp on an empty matrix's null data() is undefined even for 0 bytes (UBSan, make sanitize).
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

bool sameBits(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0;
}

/// Every SceneOptions field compared bit for bit; the first that differs is named. A material's constants
/// (mass, springs) are compared as the material gives them for the grid: a state file holds the material.
::testing::AssertionResult sameOptions(const SceneOptions& given_a, const SceneOptions& given_b) {
  const SceneOptions a = resolveMaterial(given_a);
  const SceneOptions b = resolveMaterial(given_b);
  std::vector<std::string> differ;
  const auto check = [&differ](bool same, const std::string& field) {
    if (!same) differ.push_back(field);
  };
  check(a.has_material == b.has_material, "material");
  check(a.material.preset == b.material.preset, "material.preset");
  check(sameBits(a.material.areal_density_kg_per_m2, b.material.areal_density_kg_per_m2), "material.areal_density");
  check(sameBits(a.material.stretch_modulus_N_per_m, b.material.stretch_modulus_N_per_m), "material.stretch_modulus");
  check(sameBits(a.material.shear_modulus_N_per_m, b.material.shear_modulus_N_per_m), "material.shear_modulus");
  check(sameBits(a.material.bending_rigidity_N_m, b.material.bending_rigidity_N_m), "material.bending_rigidity");
  check(sameBits(a.material.damping_s, b.material.damping_s), "material.damping");
  check(a.bend_model == b.bend_model, "bend_model");
  // Only the fields of the outline's shape count (a polygon's file has no circle).
  bool same_outline = a.outline.shape == b.outline.shape;
  if (same_outline && a.outline.shape == OutlineOptions::Shape::kCircle) {
    same_outline = sameBits(a.outline.radius_m, b.outline.radius_m) && a.outline.center_m == b.outline.center_m;
  } else if (same_outline && a.outline.shape == OutlineOptions::Shape::kPolygon) {
    same_outline = a.outline.vertices_m == b.outline.vertices_m;
  }
  check(same_outline, "outline");
  check(a.name == b.name, "name");
  check(a.rows == b.rows, "rows");
  check(a.cols == b.cols, "cols");
  check(sameBits(a.width_m, b.width_m), "width");
  check(sameBits(a.height_m, b.height_m), "height");
  check(sameBits(a.origin_m, b.origin_m), "origin");
  check(sameBits(a.u_axis, b.u_axis), "u_axis");
  check(sameBits(a.v_axis, b.v_axis), "v_axis");
  check(sameBits(a.mass_kg, b.mass_kg), "mass");
  check(sameBits(a.gravity_m_per_s2, b.gravity_m_per_s2), "gravity");
  for (int k = 0; k < kSpringKindCount; ++k) {
    const std::string kind = springKindName(static_cast<SpringKind>(k));
    check(a.springs[k].enabled == b.springs[k].enabled, kind + "_enabled");
    check(sameBits(a.springs[k].stiffness_N_per_m, b.springs[k].stiffness_N_per_m), kind + "_stiffness");
    check(sameBits(a.springs[k].damping_N_s_per_m, b.springs[k].damping_N_s_per_m), kind + "_damping");
  }
  check(sameBits(a.air_damping_N_s_per_m, b.air_damping_N_s_per_m), "air_damping");
  check(a.wind_enabled == b.wind_enabled, "wind_enabled");
  check(a.wind.model == b.wind.model, "wind_model");
  check(sameBits(a.wind.velocity_m_per_s, b.wind.velocity_m_per_s), "wind");
  check(sameBits(a.wind.paper_coefficient_N_s_per_m, b.wind.paper_coefficient_N_s_per_m), "wind_coefficient");
  check(sameBits(a.wind.air_density_kg_per_m3, b.wind.air_density_kg_per_m3), "air_density");
  check(sameBits(a.wind.drag_coefficient, b.wind.drag_coefficient), "drag_coefficient");
  check(sameBits(a.wind.gust_amplitude, b.wind.gust_amplitude), "wind_gust_amplitude");
  check(sameBits(a.wind.gust_period_s, b.wind.gust_period_s), "wind_gust_period");
  check(a.pins == b.pins, "pins");
  bool same_pin_positions = a.pin_positions_m.size() == b.pin_positions_m.size();
  for (std::size_t i = 0; same_pin_positions && i < a.pin_positions_m.size(); ++i) {
    same_pin_positions = sameBits(a.pin_positions_m[i], b.pin_positions_m[i]);
  }
  check(same_pin_positions, "pin_positions");
  check(sameBits(a.pin_travel_time_s, b.pin_travel_time_s), "pin_travel_time");
  check(sameBits(a.pin_motion_amplitude_m, b.pin_motion_amplitude_m), "pin_motion_amplitude");
  check(sameBits(a.pin_motion_period_s, b.pin_motion_period_s), "pin_motion_period");
  const ColliderSet& ca = a.colliders;
  const ColliderSet& cb = b.colliders;
  bool same_planes = ca.planes.size() == cb.planes.size();
  for (std::size_t i = 0; same_planes && i < ca.planes.size(); ++i) {
    same_planes = sameBits(ca.planes[i].normal, cb.planes[i].normal) && sameBits(ca.planes[i].offset_m, cb.planes[i].offset_m);
  }
  check(same_planes, "planes");
  bool same_spheres = ca.spheres.size() == cb.spheres.size();
  for (std::size_t i = 0; same_spheres && i < ca.spheres.size(); ++i) {
    const SphereCollider& x = ca.spheres[i];
    const SphereCollider& y = cb.spheres[i];
    same_spheres = sameBits(x.center_m, y.center_m) && sameBits(x.radius_m, y.radius_m) &&
                   sameBits(x.velocity_m_per_s, y.velocity_m_per_s) &&
                   sameBits(x.oscillation_amplitude_m, y.oscillation_amplitude_m) &&
                   sameBits(x.oscillation_period_s, y.oscillation_period_s);
  }
  check(same_spheres, "spheres");
  bool same_boxes = ca.boxes.size() == cb.boxes.size();
  for (std::size_t i = 0; same_boxes && i < ca.boxes.size(); ++i) {
    same_boxes = sameBits(ca.boxes[i].min_m, cb.boxes[i].min_m) && sameBits(ca.boxes[i].max_m, cb.boxes[i].max_m);
  }
  check(same_boxes, "boxes");
  check(sameBits(a.contact.depth_m, b.contact.depth_m), "contact_depth");
  check(sameBits(a.contact.restitution, b.contact.restitution), "restitution");
  check(sameBits(a.contact.friction, b.contact.friction), "friction");
  check(a.self_collision.enabled == b.self_collision.enabled, "self_collision");
  check(sameBits(a.self_collision.thickness_m, b.self_collision.thickness_m), "self_collision_thickness");
  check(sameBits(a.self_collision.friction, b.self_collision.friction), "self_collision_friction");
  check(sameBits(a.grasp_stiffness_N_per_m, b.grasp_stiffness_N_per_m), "grasp_stiffness");
  check(sameBits(a.grasp_damping_N_s_per_m, b.grasp_damping_N_s_per_m), "grasp_damping");
  check(a.integrator == b.integrator, "integrator");
  check(a.substeps == b.substeps, "substeps");
  check(a.guard_retries == b.guard_retries, "guard_retries");
  check(sameBits(a.sleep_speed_m_per_s, b.sleep_speed_m_per_s), "sleep_speed");
  check(sameBits(a.solver.tolerance, b.solver.tolerance), "solver_tolerance");
  check(a.solver.max_iterations == b.solver.max_iterations, "solver_max_iterations");
  check(a.solver.preconditioner == b.solver.preconditioner, "solver_preconditioner");
  check(a.threads == b.threads, "threads");
  check(sameBits(a.frame_rate_hz, b.frame_rate_hz), "frame_rate");
  check(a.texture == b.texture, "texture");
  bool same_cameras = a.cameras.size() == b.cameras.size();
  for (std::size_t i = 0; same_cameras && i < a.cameras.size(); ++i) {
    const CameraOptions& x = a.cameras[i];
    const CameraOptions& y = b.cameras[i];
    same_cameras = x.name == y.name && x.frame == y.frame && x.width == y.width && x.height == y.height &&
                   sameBits(x.fx_px, y.fx_px) && sameBits(x.fy_px, y.fy_px) && sameBits(x.cx_px, y.cx_px) &&
                   sameBits(x.cy_px, y.cy_px) && sameBits(x.rate_hz, y.rate_hz) &&
                   sameBits(x.min_range_m, y.min_range_m) && sameBits(x.max_range_m, y.max_range_m) &&
                   x.noise == y.noise && x.seed == y.seed;
  }
  check(same_cameras, "cameras");
  bool same_links = ca.frames.size() == cb.frames.size();
  for (std::size_t i = 0; same_links && i < ca.frames.size(); ++i) {
    const FrameCollider& x = ca.frames[i];
    const FrameCollider& y = cb.frames[i];
    same_links = x.frame == y.frame && x.shape == y.shape && sameBits(x.radius_m, y.radius_m) &&
                 sameBits(x.length_m, y.length_m) && sameBits(x.size_m, y.size_m) && sameBits(x.offset_m, y.offset_m) &&
                 sameBits(x.rpy_rad, y.rpy_rad);
  }
  check(same_links, "frame_colliders");
  if (differ.empty()) return ::testing::AssertionSuccess();
  std::string list;
  for (const std::string& field : differ) list += " " + field;
  return ::testing::AssertionFailure() << "fields differ:" << list;
}

bool samePose(const Pose& p, const Pose& q) {
  return sameBits(p.position_m, q.position_m) && sameBits(p.orientation.w(), q.orientation.w()) &&
         sameBits(p.orientation.x(), q.orientation.x()) && sameBits(p.orientation.y(), q.orientation.y()) &&
         sameBits(p.orientation.z(), q.orientation.z());
}

bool sameTrack(const PoseTrack& a, const PoseTrack& b) {
  return samePose(a.start, b.start) && samePose(a.end, b.end) && sameBits(a.start_time_s, b.start_time_s) &&
         sameBits(a.duration_s, b.duration_s);
}

::testing::AssertionResult sameSnapshot(const SimulationSnapshot& a, const SimulationSnapshot& b) {
  if (auto options = sameOptions(a.options, b.options); !options) return options;
  if (a.last_frame_substeps != b.last_frame_substeps) {
    return ::testing::AssertionFailure() << "last frame's substeps differ: " << a.last_frame_substeps << " and "
                                         << b.last_frame_substeps;
  }
  if (a.guard.auto_scale != b.guard.auto_scale || a.guard.consecutive_rollbacks != b.guard.consecutive_rollbacks ||
      !sameBits(a.guard.frame_motion_m_per_s, b.guard.frame_motion_m_per_s) ||
      a.guard.calm_frames != b.guard.calm_frames || a.guard.drive_fingerprint != b.guard.drive_fingerprint ||
      !sameBits(a.guard.calm_largest_step_m, b.guard.calm_largest_step_m)) {
    return ::testing::AssertionFailure() << "guard memory differs";
  }
  if (!sameMatrixBits(a.guard.calm_anchor_m, b.guard.calm_anchor_m)) {
    return ::testing::AssertionFailure() << "the calm frames' anchors differ";
  }
  const ClothState& sa = a.state;
  const ClothState& sb = b.state;
  if (!sameMatrixBits(sa.positions_m, sb.positions_m)) return ::testing::AssertionFailure() << "positions differ";
  if (!sameMatrixBits(sa.velocities_m_per_s, sb.velocities_m_per_s)) return ::testing::AssertionFailure() << "velocities differ";
  if (!sameBits(sa.time_s, sb.time_s) || sa.frame != sb.frame) return ::testing::AssertionFailure() << "time or frame differ";
  const ClothInputs& ia = a.inputs;
  const ClothInputs& ib = b.inputs;
  if (!sameBits(ia.wind_m_per_s, ib.wind_m_per_s)) return ::testing::AssertionFailure() << "wind differs";
  if (ia.pins != ib.pins) return ::testing::AssertionFailure() << "pins differ";
  if (!sameMatrixBits(ia.pin_anchors_m, ib.pin_anchors_m)) return ::testing::AssertionFailure() << "pin hooks differ";
  if (!sameMatrixBits(ia.pin_travel_m, ib.pin_travel_m)) return ::testing::AssertionFailure() << "pin travel differs";
  if (ia.grasps.size() != ib.grasps.size()) return ::testing::AssertionFailure() << "grasp counts differ";
  for (std::size_t g = 0; g < ia.grasps.size(); ++g) {
    const Grasp& x = ia.grasps[g];
    const Grasp& y = ib.grasps[g];
    if (x.id != y.id || x.particle != y.particle || !sameBits(x.target_m, y.target_m) ||
        !sameBits(x.stiffness_N_per_m, y.stiffness_N_per_m) || !sameBits(x.damping_N_s_per_m, y.damping_N_s_per_m) ||
        !sameBits(x.extra_force_N, y.extra_force_N)) {
      return ::testing::AssertionFailure() << "grasp " << g << " differs";
    }
  }
  if (ia.frame_colliders.size() != ib.frame_colliders.size()) {
    return ::testing::AssertionFailure() << "frame collider counts differ";
  }
  for (std::size_t c = 0; c < ia.frame_colliders.size(); ++c) {
    const FrameColliderTrack& x = ia.frame_colliders[c];
    const FrameColliderTrack& y = ib.frame_colliders[c];
    if (x.seen != y.seen || !sameTrack(x.track, y.track)) {
      return ::testing::AssertionFailure() << "frame collider " << c << " differs";
    }
  }
  if (ia.grippers.size() != ib.grippers.size()) return ::testing::AssertionFailure() << "gripper counts differ";
  for (std::size_t g = 0; g < ia.grippers.size(); ++g) {
    const Gripper& x = ia.grippers[g];
    const Gripper& y = ib.grippers[g];
    if (x.id != y.id || x.frame != y.frame || x.particles != y.particles || !sameMatrixBits(x.offsets_m, y.offsets_m) ||
        !sameBits(x.max_force_N, y.max_force_N) || !sameTrack(x.track, y.track)) {
      return ::testing::AssertionFailure() << "gripper " << g << " differs";
    }
  }
  return ::testing::AssertionSuccess();
}

// ---- A run with every kind of input ----------------------------------------------------------------

/// A 10x10 hanging cloth (corners 0 and 9 pinned) with the given integrator.
SceneOptions smallHanging(IntegratorKind integrator) {
  SceneOptions options = loadBuiltinScene("hanging");
  options.rows = 10;
  options.cols = 10;
  options.integrator = integrator;
  options.substeps = integrator == IntegratorKind::kImplicitEuler ? 1 : 40;
  return options;
}

/// Wind set, a pinned corner grabbed, dragged and let go (hooked again elsewhere), a free particle held,
/// the structural stiffness retuned: everything a snapshot must carry beyond the positions.
void driveWithEveryInput(Simulation& sim) {
  std::string error;
  sim.setWindVelocity(Eigen::Vector3d(1.5, 3.0, 0.0));
  for (int k = 0; k < 5; ++k) sim.advanceFrame();
  GraspRequest corner;
  corner.id = 7;
  corner.particle = 0;
  corner.target_m = sim.state().positions_m.col(0) + Eigen::Vector3d(-0.2, 0.1, 0.1);
  ASSERT_TRUE(sim.grab(corner, &error)) << error;
  GraspRequest middle;
  middle.id = 3;
  middle.particle = 55;
  middle.target_m = Eigen::Vector3d(0.1, 0.3, 1.0);
  middle.extra_force_N = Eigen::Vector3d(0.0, 0.0, 0.05);
  ASSERT_TRUE(sim.grab(middle, &error)) << error;
  for (int k = 0; k < 8; ++k) sim.advanceFrame();
  ASSERT_TRUE(sim.release(7));
  SceneOptions tuned = sim.options();
  tuned.springs[static_cast<int>(SpringKind::kStructural)].stiffness_N_per_m *= 1.5;
  tuned.air_damping_N_s_per_m = 0.01;
  // A forearm on a tf frame, swept into the cloth from the front.
  FrameCollider forearm;
  forearm.frame = "forearm";
  forearm.shape = ShapeKind::kCapsule;
  forearm.radius_m = 0.05;
  forearm.length_m = 0.3;
  forearm.rpy_rad = Eigen::Vector3d(0.0, 0.5, 0.0);
  tuned.colliders.frames = {forearm};
  ASSERT_TRUE(sim.retune(tuned, &error)) << error;
  for (int k = 0; k < 4; ++k) {
    Pose frame;
    frame.position_m = Eigen::Vector3d(0.0, -0.2 + 0.05 * k, 1.2);
    frame.orientation = Eigen::AngleAxisd(0.2 * k, Eigen::Vector3d::UnitX());
    ASSERT_TRUE(sim.moveFrameCollider(0, frame, &error)) << error;
    sim.advanceFrame();
  }
  // A gripper holding the particles near the middle, carried up and turned over three frames.
  GripperRequest hand;
  hand.id = 11;
  hand.frame = "hand";
  hand.pose.position_m = sim.state().positions_m.col(45);
  hand.radius_m = 0.15;
  hand.max_force_N = 50.0;
  std::vector<int> held;
  ASSERT_TRUE(sim.attachGripper(hand, &held, &error)) << error;
  ASSERT_GT(held.size(), 1u);
  for (int k = 1; k <= 3; ++k) {
    Pose moved = hand.pose;
    moved.position_m += Eigen::Vector3d(0.0, 0.01 * k, 0.02 * k);
    moved.orientation = Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d::UnitZ());
    ASSERT_TRUE(sim.moveGripper(hand.id, moved, &error)) << error;
    sim.advanceFrame();
  }
}

/// A folder of its own for one test, removed with everything in it when the test ends (pass or fail).
class TempFolder {
 public:
  TempFolder() {
    static int folders = 0;
    path_ = fs::temp_directory_path() /
            ("cloth_sim_state_test_" + std::to_string(::getpid()) + "_" + std::to_string(folders++));
    fs::create_directories(path_);
  }
  ~TempFolder() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  std::string path() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

class EveryIntegrator : public ::testing::TestWithParam<IntegratorKind> {};

TEST_P(EveryIntegrator, SaveRestoreAndAdvanceGivesTheBitsOfTheUninterruptedRun) {
  const SceneOptions scene = smallHanging(GetParam());
  Simulation original(scene);
  driveWithEveryInput(original);
  if (HasFatalFailure()) return;
  const SimulationSnapshot saved = original.snapshot();
  ASSERT_FALSE(sameBits(Eigen::Vector3d(saved.inputs.pin_anchors_m.col(0)), Eigen::Vector3d(original.grid().rest_positions_m.col(0))))
      << "the released corner must hang on a new hook, or the test proves nothing about hooks";
  ASSERT_EQ(saved.inputs.grasps.size(), 1u);
  ASSERT_EQ(saved.inputs.grippers.size(), 1u);

  const TempFolder folder;
  const std::string path = folder.file(std::string(integratorName(GetParam())) + ".clothstate");
  std::string error;
  ASSERT_TRUE(writeStateFile(path, saved, &error)) << error;
  SimulationSnapshot loaded;
  ASSERT_TRUE(readStateFile(path, &loaded, &error)) << error;
  ASSERT_TRUE(sameSnapshot(saved, loaded));

  Simulation restored(scene);  // the scene as loaded: untuned, no wind, no grasps, at frame 0
  ASSERT_TRUE(restored.restore(loaded, &error)) << error;
  ASSERT_TRUE(sameSnapshot(original.snapshot(), restored.snapshot()));

  // Without its inputs the same state continues differently: the inputs are what is being tested.
  Simulation inputs_dropped(scene);
  SimulationSnapshot bare = loaded;
  bare.inputs = inputs_dropped.inputs();
  bare.options = scene;
  ASSERT_TRUE(inputs_dropped.restore(bare, &error)) << error;

  constexpr int kFramesAfter = 30;
  for (int k = 0; k < kFramesAfter; ++k) {
    original.advanceFrame();
    restored.advanceFrame();
    inputs_dropped.advanceFrame();
    ASSERT_TRUE(sameMatrixBits(original.state().positions_m, restored.state().positions_m)) << "frame " << k + 1;
    ASSERT_TRUE(sameMatrixBits(original.state().velocities_m_per_s, restored.state().velocities_m_per_s)) << "frame " << k + 1;
  }
  EXPECT_TRUE(sameSnapshot(original.snapshot(), restored.snapshot()));
  EXPECT_FALSE(sameMatrixBits(saved.state.positions_m, restored.state().positions_m)) << "the cloth did not move";
  EXPECT_FALSE(sameMatrixBits(original.state().positions_m, inputs_dropped.state().positions_m))
      << "dropping grasps, hooks, wind and tuning changed nothing: the comparison proves nothing";
}

INSTANTIATE_TEST_SUITE_P(Snapshot, EveryIntegrator, ::testing::ValuesIn(kAllIntegrators),
                         [](const ::testing::TestParamInfo<IntegratorKind>& info) {
                           return std::string(integratorName(info.param));
                         });

TEST(Snapshot, EveryBuiltinSceneContinuesBitExactlyThroughAFile) {
  for (const std::string& name : builtinSceneNames(test::scenesDir())) {
    SceneOptions scene = loadBuiltinScene(name);
    scene.rows = std::min(scene.rows, 12);
    scene.cols = std::min(scene.cols, 12);
    scene.pin_positions_m.clear();  // they are per pinned particle of the full-size grid
    scene.texture.clear();
    Simulation original(scene);
    for (int k = 0; k < 10; ++k) original.advanceFrame();
    SimulationSnapshot loaded;
    std::string error;
    ASSERT_TRUE(decodeStateFile(encodeStateFile(original.snapshot()), &loaded, &error)) << name << ": " << error;
    Simulation restored(scene);
    ASSERT_TRUE(restored.restore(loaded, &error)) << name << ": " << error;
    for (int k = 0; k < 10; ++k) {
      original.advanceFrame();
      restored.advanceFrame();
    }
    EXPECT_TRUE(sameSnapshot(original.snapshot(), restored.snapshot())) << name;
  }
}

// ---- restore refuses, all or nothing ---------------------------------------------------------------

/// restore(bad) must fail, with a reason holding `expected`, and leave the simulation as it was.
void expectRefused(const std::function<void(SimulationSnapshot&)>& damage, const std::string& expected) {
  Simulation sim(smallHanging(IntegratorKind::kImplicitEuler));
  driveWithEveryInput(sim);
  const SimulationSnapshot before = sim.snapshot();
  SimulationSnapshot bad = before;
  damage(bad);
  std::string error;
  EXPECT_FALSE(sim.restore(bad, &error)) << "accepted; expected a refusal with '" << expected << "'";
  EXPECT_NE(error.find(expected), std::string::npos) << "'" << expected << "' not in: " << error;
  EXPECT_TRUE(sameSnapshot(before, sim.snapshot())) << "a refused restore changed the simulation";
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Restore, AnotherGridIsRefusedNamingWhatDiffers) {
  expectRefused([](SimulationSnapshot& s) { s.options.rows = 11; }, "grid differs from this scene's (10x10) in rows, cols");
  expectRefused([](SimulationSnapshot& s) { s.options.mass_kg *= 2.0; }, "grid differs from this scene's (10x10) in mass, material");
  expectRefused([](SimulationSnapshot& s) { s.options.pins = {"top_edge"}; }, "grid differs from this scene's (10x10) in pins");
  expectRefused([](SimulationSnapshot& s) { s.options.origin_m.x() += 0.1; }, "in origin, u_axis, v_axis");
}

TEST(Restore, InvalidOptionsAreRefusedByName) {
  expectRefused([](SimulationSnapshot& s) { s.options.substeps = -1; }, "substeps");
  expectRefused([](SimulationSnapshot& s) { s.guard.auto_scale = 3; }, "guard memory");
  expectRefused([](SimulationSnapshot& s) { s.guard.consecutive_rollbacks = -1; }, "guard memory");
  expectRefused([](SimulationSnapshot& s) { s.guard.frame_motion_m_per_s = std::nan(""); }, "guard memory");
  expectRefused([](SimulationSnapshot& s) { s.guard.frame_motion_m_per_s = -1.0; }, "guard memory");
  expectRefused([](SimulationSnapshot& s) { s.guard.calm_frames = -1; }, "guard memory");
  expectRefused([](SimulationSnapshot& s) { s.guard.calm_frames = Simulation::sleepAfterFrames(s.options) + 1; }, "guard memory");
  // The calm frames' anchor: one finite position per particle while there are calm frames, none else;
  // their largest step within twice the allowance, 0 while there are none.
  const auto calm = [](SimulationSnapshot& s) {
    s.guard.calm_frames = 3;
    s.guard.calm_anchor_m = s.state.positions_m;
  };
  expectRefused([](SimulationSnapshot& s) { s.guard.calm_anchor_m = s.state.positions_m; }, "anchor (one position");
  expectRefused([](SimulationSnapshot& s) { s.guard.calm_frames = 3; }, "anchor (one position");
  expectRefused([&](SimulationSnapshot& s) { calm(s); s.guard.calm_anchor_m(1, 7) = kNaN; }, "anchor (one position per particle while there are calm frames, else none)[7]");
  expectRefused([&](SimulationSnapshot& s) { calm(s); s.guard.calm_anchor_m(2, 0) = 2e3; }, "anchor (one position per particle while there are calm frames, else none)[0]");
  expectRefused([&](SimulationSnapshot& s) { calm(s); s.guard.calm_largest_step_m = -1e-9; }, "largest step");
  expectRefused([&](SimulationSnapshot& s) { calm(s); s.guard.calm_largest_step_m = kNaN; }, "largest step");
  expectRefused([&](SimulationSnapshot& s) {
    calm(s);
    s.guard.calm_largest_step_m = 2.0 * Simulation::sleepAllowance_m(s.options) * (1.0 + 1e-12);
  }, "largest step");
  expectRefused([](SimulationSnapshot& s) { s.guard.calm_largest_step_m = 1e-6; }, "largest step");
  expectRefused([](SimulationSnapshot& s) { s.options.springs[0].stiffness_N_per_m = kNaN; }, "stiffness");
}

TEST(Restore, AStateOfAnotherSizeOrNotFiniteOrOutOfBoundsIsRefused) {
  expectRefused([](SimulationSnapshot& s) { s.state.positions_m.conservativeResize(3, 99); }, "positions");
  expectRefused([](SimulationSnapshot& s) { s.state.velocities_m_per_s.resize(3, 0); }, "velocities");
  expectRefused([](SimulationSnapshot& s) { s.state.positions_m(1, 42) = kNaN; }, "positions[42]");
  expectRefused([](SimulationSnapshot& s) { s.state.positions_m(2, 5) = 2.0 * Simulation::kDivergenceBound_m; },
                "positions[5]");
  expectRefused([](SimulationSnapshot& s) { s.state.velocities_m_per_s(0, 7) = kInf; }, "velocities[7]");
  expectRefused([](SimulationSnapshot& s) { s.state.time_s = kNaN; }, "time");
  expectRefused([](SimulationSnapshot& s) { s.state.time_s = -1.0; }, "time");
}

TEST(Restore, InputsThatDoNotFitAreRefused) {
  expectRefused([](SimulationSnapshot& s) { s.inputs.pins = {0, 5}; }, "pin");
  expectRefused([](SimulationSnapshot& s) { s.inputs.pin_anchors_m.resize(3, 1); }, "pin hooks");
  expectRefused([](SimulationSnapshot& s) { s.inputs.pin_anchors_m(0, 1) = kNaN; }, "pin hooks[1]");
  expectRefused([](SimulationSnapshot& s) { s.inputs.pin_travel_m(2, 0) = kInf; }, "pin travel[0]");
  expectRefused([](SimulationSnapshot& s) { s.inputs.wind_m_per_s.x() = kNaN; }, "wind");
  expectRefused(
      [](SimulationSnapshot& s) { s.inputs.wind_m_per_s = {OptionLimits::kMaxWindSpeed_m_per_s + 1.0, 0.0, 0.0}; },
      "wind");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).particle = 100; }, "particle 100");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).particle = -1; }, "particle -1");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).target_m.y() = kInf; }, "target");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).stiffness_N_per_m = kNaN; }, "stiffness");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).damping_N_s_per_m = -1.0; }, "damping");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.at(0).extra_force_N.z() = kNaN; }, "force");
  expectRefused([](SimulationSnapshot& s) { s.inputs.grasps.push_back(s.inputs.grasps.at(0)); }, "unique");
  expectRefused(
      [](SimulationSnapshot& s) {
        for (std::uint32_t id = 100; s.inputs.grasps.size() <= Simulation::kMaxGrasps; ++id) {
          Grasp extra = s.inputs.grasps.at(0);
          extra.id = id;
          s.inputs.grasps.push_back(extra);
        }
      },
      "at most 16");
}

TEST(Restore, RestoreStateChecksItsInputAndKeepsOptionsAndInputs) {
  Simulation sim(smallHanging(IntegratorKind::kImplicitEuler));
  driveWithEveryInput(sim);
  const SimulationSnapshot before = sim.snapshot();
  std::string error;
  ClothState bad = before.state;
  bad.positions_m(0, 3) = kNaN;
  EXPECT_FALSE(sim.restoreState(bad, &error));
  EXPECT_NE(error.find("positions[3]"), std::string::npos) << error;
  bad = before.state;
  bad.velocities_m_per_s.resize(3, 4);
  EXPECT_FALSE(sim.restoreState(bad, &error));
  EXPECT_NE(error.find("velocities"), std::string::npos) << error;
  EXPECT_TRUE(sameSnapshot(before, sim.snapshot()));

  for (int k = 0; k < 3; ++k) sim.advanceFrame();
  // Advancing moves the inputs on too (a gripper no one moved holds still from the new frame on): only
  // the state goes back.
  SimulationSnapshot expected = sim.snapshot();
  ASSERT_TRUE(std::isfinite(expected.guard.frame_motion_m_per_s));
  expected.state = before.state;
  // The last frame's motion was the old state's: a state put in has not been seen moving yet.
  expected.guard.frame_motion_m_per_s = GuardMemory().frame_motion_m_per_s;
  expected.guard.forgetCalm();
  ASSERT_TRUE(sim.restoreState(before.state, &error)) << error;
  EXPECT_TRUE(sameSnapshot(expected, sim.snapshot())) << "restoreState must bring back the state, inputs untouched";
}

TEST(Restore, TheLastFrameSubstepsComeBackWithTheState) {
  // A loaded frame reports the substeps the run that saved it computed it with (ClothState.substeps, the
  // node's first message after ~load_state), not those of the frame the loading run was at.
  SceneOptions options = smallHanging(IntegratorKind::kSymplecticEuler);
  Simulation saver(options);
  for (int k = 0; k < 3; ++k) saver.advanceFrame();
  SceneOptions retuned = saver.options();
  retuned.substeps = 3 * options.substeps;
  std::string error;
  ASSERT_TRUE(saver.retune(retuned, &error)) << error;
  ASSERT_EQ(saver.advanceFrame().substeps_used, retuned.substeps);
  SimulationSnapshot loaded;
  ASSERT_TRUE(decodeStateFile(encodeStateFile(saver.snapshot()), &loaded, &error)) << error;
  EXPECT_EQ(loaded.last_frame_substeps, retuned.substeps);

  Simulation loader(options);
  loader.advanceFrame();
  ASSERT_EQ(loader.lastFrameSubsteps(), options.substeps);
  ASSERT_TRUE(loader.restore(loaded, &error)) << error;
  EXPECT_EQ(loader.lastFrameSubsteps(), retuned.substeps);
  EXPECT_TRUE(sameSnapshot(saver.snapshot(), loader.snapshot()));

  // Not known (a file before version 6, a state put in by hand): what the next frame will take.
  loaded.last_frame_substeps = 0;
  Simulation old_file(options);
  ASSERT_TRUE(old_file.restore(loaded, &error)) << error;
  EXPECT_EQ(old_file.lastFrameSubsteps(), retuned.substeps);
  EXPECT_EQ(old_file.advanceFrame().substeps_used, retuned.substeps);
  // A state put in by hand was not computed here either: what the next frame starts from (the loader
  // retuned to another count first, so the saved frame's count would not pass for it).
  SceneOptions again = loader.options();
  again.substeps = 2 * options.substeps;
  ASSERT_TRUE(loader.retune(again, &error)) << error;
  ASSERT_EQ(loader.lastFrameSubsteps(), retuned.substeps);
  ASSERT_TRUE(loader.restoreState(saver.state(), &error)) << error;
  EXPECT_EQ(loader.lastFrameSubsteps(), again.substeps);
}

TEST(Restore, BeforeItsFirstFrameASimulationReportsTheSubstepsTheFirstWillTake) {
  SceneOptions options = smallHanging(IntegratorKind::kSymplecticEuler);
  for (const int substeps : {options.substeps, 0}) {  // fixed, then `auto`
    options.substeps = substeps;
    Simulation sim(options);
    const int before = sim.lastFrameSubsteps();
    EXPECT_EQ(sim.advanceFrame().substeps_used, before) << "substeps " << substeps;
    EXPECT_GT(before, 1) << "the explicit integrator needs several: the test would not tell 1 from them";
    sim.reset();
    EXPECT_EQ(sim.lastFrameSubsteps(), before) << "after a reset";
  }
}

TEST(Restore, ALastFrameSubstepCountOutOfRangeIsRefused) {
  expectRefused([](SimulationSnapshot& s) { s.last_frame_substeps = -1; }, "last frame's substeps -1");
  expectRefused([](SimulationSnapshot& s) { s.last_frame_substeps = OptionLimits::kMaxSubsteps + 1; },
                "last frame's substeps");
}

// ---- The scene writer ------------------------------------------------------------------------------

SceneOptions readBack(const std::string& text);

std::set<std::string> emittedKeys(const SceneOptions& options) {
  const YAML::Node map = YAML::Load(sceneYaml(options));
  std::set<std::string> emitted;
  if (!map.IsMap()) return emitted;
  for (const auto& entry : map) emitted.insert(entry.first.Scalar());
  return emitted;
}

TEST(SceneYaml, EmitsEveryKeyOfTheSceneMapAndNothingElse) {
  // The paper's constants, or a material instead of them (mass and the springs' nine keys).
  std::set<std::string> keys(sceneKeys().begin(), sceneKeys().end());
  EXPECT_GT(keys.size(), 40u) << "sceneKeys() looks too short to prove anything";
  std::set<std::string> paper_keys = keys;
  paper_keys.erase("material");
  EXPECT_EQ(emittedKeys(SceneOptions()), paper_keys);
  SceneOptions denim;
  denim.has_material = true;
  ASSERT_TRUE(findMaterialPreset("denim", &denim.material));
  std::set<std::string> material_keys = keys;
  material_keys.erase("mass");
  for (const char* kind : {"structural", "shear", "bend"}) {
    for (const char* field : {"_enabled", "_stiffness", "_damping"}) material_keys.erase(std::string(kind) + field);
  }
  EXPECT_EQ(emittedKeys(denim), material_keys);
  EXPECT_TRUE(sameOptions(denim, readBack(sceneYaml(denim))));
  // Outlines read back exactly too.
  denim.outline.shape = OutlineOptions::Shape::kCircle;
  denim.outline.center_m = Eigen::Vector2d(0.5, 0.1 + 0.2);
  denim.outline.radius_m = 0.3;
  EXPECT_TRUE(sameOptions(denim, readBack(sceneYaml(denim))));
  denim.outline.shape = OutlineOptions::Shape::kPolygon;
  denim.outline.vertices_m = {{0.0, 0.0}, {1.0, 0.0}, {0.5, 1.0 / 3.0}};
  EXPECT_TRUE(sameOptions(denim, readBack(sceneYaml(denim))));
}

SceneOptions readBack(const std::string& text) {
  SceneOptions read;
  std::vector<std::string> errors;
  EXPECT_TRUE(applySceneYaml(YAML::Load(text), "test", &read, &errors)) << (errors.empty() ? "" : errors.front());
  return read;
}

TEST(SceneYaml, EveryBuiltinSceneReadsBackExactly) {
  const std::vector<std::string> names = builtinSceneNames(test::scenesDir());
  ASSERT_GE(names.size(), 7u);
  for (const std::string& name : names) {
    const SceneOptions scene = loadBuiltinScene(name);
    EXPECT_TRUE(sameOptions(scene, readBack(sceneYaml(scene)))) << name;
  }
}

/// A double anywhere in its range: random bits, skipping NaN and infinities (options never hold them),
/// so subnormals, -0 and the largest values all occur.
double anyFiniteDouble(std::mt19937_64& random) {
  while (true) {
    const std::uint64_t bits = random();
    double value;
    std::memcpy(&value, &bits, sizeof(value));
    if (std::isfinite(value)) return value;
  }
}

std::string anyString(std::mt19937_64& random) {
  // Strings YAML would otherwise read as something else, or that need escaping.
  static const std::vector<std::string> tricky{"",      "42",   "yes",   "null", "~",      "- a",  "a: b",
                                               "\"q\"", "'s'",  "#c",    "x\ny", "tab\tx", "é ü",  " lead",
                                               "trail ", "[1]", "{a: 1}", "&a",  "*a",     "!tag", "0x1p3"};
  std::string text = tricky[random() % tricky.size()];
  const int extra = static_cast<int>(random() % 4);
  for (int i = 0; i < extra; ++i) text += static_cast<char>(' ' + random() % 95);
  return text;
}

SceneOptions randomOptions(std::mt19937_64& random) {
  const auto d = [&random] { return anyFiniteDouble(random); };
  const auto v = [&d] { return Eigen::Vector3d(d(), d(), d()); };
  const auto i = [&random] { return static_cast<int>(random()); };
  const auto b = [&random] { return random() % 2 == 0; };
  const auto count = [&random] { return static_cast<int>(random() % 4); };
  SceneOptions o;
  o.name = anyString(random);
  o.rows = i();
  o.cols = i();
  o.width_m = d();
  o.height_m = d();
  o.origin_m = v();
  o.u_axis = v();
  o.v_axis = v();
  o.mass_kg = d();
  o.gravity_m_per_s2 = v();
  for (SpringOptions& spring : o.springs) spring = {b(), d(), d()};
  o.air_damping_N_s_per_m = d();
  o.wind_enabled = b();
  o.wind.model = b() ? WindModel::kPaper : WindModel::kAerodynamic;
  o.wind.velocity_m_per_s = v();
  o.wind.paper_coefficient_N_s_per_m = d();
  o.wind.air_density_kg_per_m3 = d();
  o.wind.drag_coefficient = d();
  o.wind.gust_amplitude = d();
  o.wind.gust_period_s = d();
  o.pins.clear();
  for (int k = count(); k > 0; --k) o.pins.push_back(anyString(random));
  o.pin_positions_m.clear();
  for (int k = count(); k > 0; --k) o.pin_positions_m.push_back(v());
  o.pin_travel_time_s = d();
  o.pin_motion_amplitude_m = v();
  o.pin_motion_period_s = d();
  for (int k = count(); k > 0; --k) o.colliders.planes.push_back({v(), d()});
  for (int k = count(); k > 0; --k) o.colliders.spheres.push_back({v(), d(), v(), v(), d()});
  for (int k = count(); k > 0; --k) o.colliders.boxes.push_back({v(), v()});
  o.contact = {d(), d(), d()};
  o.grasp_stiffness_N_per_m = d();
  o.grasp_damping_N_s_per_m = d();
  o.integrator = kAllIntegrators[random() % std::size(kAllIntegrators)];
  o.substeps = i();
  o.guard_retries = random() % 2 == 0;
  o.sleep_speed_m_per_s = d();
  o.solver.tolerance = d();
  o.solver.max_iterations = i();
  o.solver.preconditioner = allPreconditionerKinds()[random() % allPreconditionerKinds().size()];
  o.threads = i();
  o.frame_rate_hz = d();
  o.texture = anyString(random);
  for (int k = count(); k > 0; --k) {
    CameraOptions camera;
    camera.name = anyString(random);
    camera.frame = anyString(random);
    camera.width = i();
    camera.height = i();
    camera.fx_px = d();
    camera.fy_px = d();
    camera.cx_px = d();
    camera.cy_px = d();
    camera.rate_hz = d();
    camera.min_range_m = d();
    camera.max_range_m = d();
    camera.noise = b() ? DepthNoise::kKinect : DepthNoise::kNone;
    camera.seed = static_cast<std::uint32_t>(random() % (static_cast<std::uint64_t>(INT32_MAX) + 1));  // the int range
    o.cameras.push_back(camera);
  }
  return o;
}

TEST(SceneYaml, RandomisedOptionsReadBackExactly) {
  std::mt19937_64 random(20261123);  // fixed: a failure reproduces
  constexpr int kCases = 300;
  for (int c = 0; c < kCases; ++c) {
    const SceneOptions options = randomOptions(random);
    const std::string text = sceneYaml(options);
    ASSERT_TRUE(sameOptions(options, readBack(text))) << "case " << c << ":\n" << text;
  }
  // The extremes by name: the smallest subnormal, the largest double, -0.
  SceneOptions extremes;
  extremes.width_m = std::numeric_limits<double>::denorm_min();
  extremes.height_m = std::numeric_limits<double>::max();
  extremes.mass_kg = -0.0;
  extremes.frame_rate_hz = 0.1;
  EXPECT_TRUE(sameOptions(extremes, readBack(sceneYaml(extremes))));
}

// ---- The state file ----------------------------------------------------------------------------------

SimulationSnapshot drivenSnapshot() {
  Simulation sim(smallHanging(IntegratorKind::kImplicitEuler));
  driveWithEveryInput(sim);
  return sim.snapshot();
}

/// Header fields (doc/STATE_FILE.md).
constexpr std::size_t kMarkOffset = 8;
constexpr std::size_t kVersionOffset = 12;
constexpr std::size_t kLengthOffset = 16;
constexpr std::size_t kChecksumOffset = 24;

template <typename T>
void poke(std::string& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

/// Recomputes the header's CRC-32 after a deliberate change of the payload (to reach the checks behind it).
std::string withChecksum(std::string bytes) {
  poke(bytes, kChecksumOffset,
       crc32(bytes.data() + StateFileFormat::kHeaderBytes, bytes.size() - StateFileFormat::kHeaderBytes));
  return bytes;
}

void expectDecodeFails(const std::string& bytes, const std::string& expected) {
  SimulationSnapshot snapshot;
  snapshot.state.frame = 12345;
  std::string error;
  EXPECT_FALSE(decodeStateFile(bytes, &snapshot, &error)) << "accepted; expected '" << expected << "'";
  EXPECT_NE(error.find(expected), std::string::npos) << "'" << expected << "' not in: " << error;
  EXPECT_EQ(snapshot.state.frame, 12345u) << "a refused file changed the output";
}

TEST(StateFile, Crc32IsTheStandardOne) {
  const std::string check = "123456789";  // the CRC catalogue's check input
  EXPECT_EQ(crc32(check.data(), check.size()), 0xCBF43926u);
}

TEST(StateFile, RoundTripIsBitExact) {
  const SimulationSnapshot saved = drivenSnapshot();
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(encodeStateFile(saved), &loaded, &error)) << error;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
  EXPECT_EQ(encodeStateFile(loaded), encodeStateFile(saved)) << "writing it again gives other bytes";
}

/// The CALM section (version 4 on): a tag, an 8-byte length and the last frame's motion (a double).
constexpr std::size_t kMotionSectionBytes = 4 + 8 + 8;
/// The SLEP section (version 5 on): a tag, an 8-byte length, the calm frames (int32) and the drive (uint64).
constexpr std::size_t kSleepSectionBytes = 4 + 8 + 4 + 8;
/// The LAST section (version 6 on): a tag, an 8-byte length and the saved frame's substeps (int32).
constexpr std::size_t kLastSectionBytes = 4 + 8 + 4;
/// The ANCH section (version 7 on): a tag, an 8-byte length, the largest calm step (a double), a count
/// (uint64) and the anchor's positions.
std::size_t anchorSectionBytes(const SimulationSnapshot& snapshot) {
  return 4 + 8 + 8 + 8 + 3 * sizeof(double) * static_cast<std::size_t>(snapshot.guard.calm_anchor_m.cols());
}

/// bytes, an encoded file, cut to its first `version`'s sections: the last `cut` bytes dropped.
std::string asOlderVersion(std::string bytes, std::uint32_t version, std::size_t cut) {
  bytes.resize(bytes.size() - cut);
  poke(bytes, kVersionOffset, version);
  poke(bytes, kLengthOffset, static_cast<std::uint64_t>(bytes.size() - StateFileFormat::kHeaderBytes));
  return withChecksum(bytes);
}

/// A snapshot of a cloth that has come to rest under no drive at all: asleep.
SimulationSnapshot sleepingSnapshot() {
  SceneOptions options = smallHanging(IntegratorKind::kImplicitEuler);
  options.pins.clear();
  options.colliders.planes = {PlaneCollider{}};
  options.origin_m = Eigen::Vector3d(0.0, 0.0, 0.001);
  options.u_axis = Eigen::Vector3d::UnitX();
  options.v_axis = Eigen::Vector3d::UnitY();
  Simulation sim(options);
  for (int k = 0; k < 200 && !sim.advanceFrame().asleep; ++k) {
  }
  return sim.snapshot();
}

TEST(StateFile, AVersion5FileStillLoadsWithTheLastFrameSubstepsUnknown) {
  SimulationSnapshot saved = drivenSnapshot();
  saved.last_frame_substeps = 4;
  const std::string bytes = encodeStateFile(saved);
  const std::size_t anchor = anchorSectionBytes(saved);
  ASSERT_EQ(bytes.substr(bytes.size() - anchor - kLastSectionBytes, 4), "LAST");
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(bytes, &loaded, &error)) << error;
  EXPECT_EQ(loaded.last_frame_substeps, 4) << "version 6 on keeps the saved frame's substeps";
  ASSERT_TRUE(decodeStateFile(asOlderVersion(bytes, 5, anchor + kLastSectionBytes), &loaded, &error)) << error;
  EXPECT_EQ(loaded.last_frame_substeps, 0) << "an older file does not know them";
  saved.last_frame_substeps = 0;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
}

TEST(StateFile, AVersion6FilesCalmClothCountsItsCalmFramesFromWhereItWasSaved) {
  SimulationSnapshot saved = sleepingSnapshot();
  ASSERT_EQ(saved.guard.calm_frames, Simulation::sleepAfterFrames(saved.options)) << "the sheet on the floor never slept";
  ASSERT_EQ(saved.guard.calm_anchor_m.cols(), saved.state.particleCount()) << "asleep with no anchor";
  const std::string bytes = encodeStateFile(saved);
  const std::size_t anchor = anchorSectionBytes(saved);
  ASSERT_EQ(bytes.substr(bytes.size() - anchor, 4), "ANCH");
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(asOlderVersion(bytes, 6, anchor), &loaded, &error)) << error;
  // Version 6 counted calm frames frame to frame and kept no anchor: the saved positions stand in for it,
  // and each of its calm frames moved less than sleep_speed in a frame (a largest step of 0).
  EXPECT_EQ(loaded.guard.calm_frames, saved.guard.calm_frames);
  saved.guard.calm_anchor_m = saved.state.positions_m;
  saved.guard.calm_largest_step_m = 0.0;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
  Simulation simulation(loaded.options);
  ASSERT_TRUE(simulation.restore(loaded, &error)) << error;
  EXPECT_TRUE(simulation.advanceFrame().asleep) << "a cloth saved asleep by version 6 woke when loaded";
}

TEST(StateFile, AVersion4FileStillLoadsAwake) {
  SimulationSnapshot saved = sleepingSnapshot();
  ASSERT_EQ(saved.guard.calm_frames, Simulation::sleepAfterFrames(saved.options)) << "the sheet on the floor never slept";
  const std::string bytes = encodeStateFile(saved);
  const std::size_t anchor = anchorSectionBytes(saved);
  ASSERT_EQ(bytes.substr(bytes.size() - anchor - kLastSectionBytes - kSleepSectionBytes, 4), "SLEP");
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(bytes, &loaded, &error)) << error;
  EXPECT_TRUE(sameSnapshot(saved, loaded)) << "version 7 keeps the sleep count and its anchor";
  ASSERT_TRUE(
      decodeStateFile(asOlderVersion(bytes, 4, anchor + kLastSectionBytes + kSleepSectionBytes), &loaded, &error))
      << error;
  EXPECT_EQ(loaded.guard.calm_frames, 0) << "an older file's cloth must be seen at rest before it sleeps";
  saved.guard.forgetCalm();
  saved.guard.drive_fingerprint = 0;
  saved.last_frame_substeps = 0;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
}

TEST(StateFile, AVersion3FileStillLoadsWithNoFrameMotionMeasured) {
  SimulationSnapshot saved = drivenSnapshot();
  ASSERT_TRUE(std::isfinite(saved.guard.frame_motion_m_per_s)) << "the driven run measured no frame";
  const std::string bytes = encodeStateFile(saved);
  const std::size_t kNewer = kMotionSectionBytes + kSleepSectionBytes + kLastSectionBytes + anchorSectionBytes(saved);
  ASSERT_EQ(bytes.substr(bytes.size() - kNewer, 4), "CALM");
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(asOlderVersion(bytes, 3, kNewer), &loaded, &error)) << error;
  EXPECT_TRUE(std::isinf(loaded.guard.frame_motion_m_per_s)) << "an older file's cloth must not count as calm";
  saved.guard.frame_motion_m_per_s = GuardMemory().frame_motion_m_per_s;
  saved.guard.forgetCalm();
  saved.guard.drive_fingerprint = 0;
  saved.last_frame_substeps = 0;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
}

TEST(StateFile, AVersion2FileStillLoadsWithNoGrippersOrLinkPoses) {
  SimulationSnapshot saved = drivenSnapshot();
  saved.inputs.grippers.clear();
  saved.inputs.frame_colliders.clear();
  saved.options.colliders.frames.clear();
  const std::string bytes = encodeStateFile(saved);
  // Version 2 is version 7 without the last six sections: GRIP and LINK, each a tag, an 8-byte length
  // and an 8-byte count of 0, CALM, SLEP, LAST and ANCH.
  constexpr std::size_t kEmptySectionBytes = 4 + 8 + 8;
  const std::size_t kNewer = kSleepSectionBytes + kMotionSectionBytes + kLastSectionBytes + anchorSectionBytes(saved);
  ASSERT_EQ(bytes.substr(bytes.size() - kNewer - 2 * kEmptySectionBytes, 4), "GRIP");
  ASSERT_EQ(bytes.substr(bytes.size() - kNewer - kEmptySectionBytes, 4), "LINK");
  SimulationSnapshot loaded;
  std::string error;
  ASSERT_TRUE(decodeStateFile(asOlderVersion(bytes, 2, kNewer + 2 * kEmptySectionBytes), &loaded, &error)) << error;
  saved.guard.frame_motion_m_per_s = GuardMemory().frame_motion_m_per_s;
  saved.guard.forgetCalm();
  saved.guard.drive_fingerprint = 0;
  saved.last_frame_substeps = 0;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
}

TEST(StateFile, EveryTruncationIsRefused) {
  const std::string bytes = encodeStateFile(drivenSnapshot());
  // Every cut inside the header, then a spread through the payload, and one byte short.
  std::vector<std::size_t> cuts;
  for (std::size_t n = 0; n < StateFileFormat::kHeaderBytes; ++n) cuts.push_back(n);
  for (std::size_t n = StateFileFormat::kHeaderBytes; n < bytes.size(); n += 97) cuts.push_back(n);
  cuts.push_back(bytes.size() - 1);
  for (const std::size_t n : cuts) {
    SimulationSnapshot snapshot;
    std::string error;
    EXPECT_FALSE(decodeStateFile(bytes.substr(0, n), &snapshot, &error)) << "a file cut to " << n << " bytes was accepted";
    if (n >= sizeof(StateFileFormat::kMagic)) {
      EXPECT_NE(error.find("truncated"), std::string::npos) << n << " bytes: " << error;
    }
  }
}

TEST(StateFile, EveryFlippedPayloadByteIsCaughtByTheChecksum) {
  const std::string bytes = encodeStateFile(drivenSnapshot());
  for (std::size_t at = StateFileFormat::kHeaderBytes; at < bytes.size(); at += 13) {
    std::string damaged = bytes;
    damaged[at] = static_cast<char>(damaged[at] ^ 0x10);
    expectDecodeFails(damaged, "CRC-32");
  }
}

TEST(StateFile, WrongMagicVersionOrByteOrderIsRefusedWithTheReason) {
  const std::string bytes = encodeStateFile(drivenSnapshot());
  std::string damaged = bytes;
  damaged[0] = 'X';
  expectDecodeFails(damaged, "not a cloth_sim state file");
  damaged = bytes;
  poke(damaged, kVersionOffset, std::uint32_t{0});
  expectDecodeFails(damaged, "version 0 is not supported");
  damaged = bytes;
  poke(damaged, kVersionOffset, StateFileFormat::kVersion + 1);
  expectDecodeFails(damaged, "version " + std::to_string(StateFileFormat::kVersion + 1) + " is not supported");
  damaged = bytes;
  std::reverse(damaged.begin() + kMarkOffset, damaged.begin() + kMarkOffset + 4);
  expectDecodeFails(damaged, "other byte order");
  damaged = bytes;
  poke(damaged, kMarkOffset, std::uint32_t{0xdeadbeef});
  expectDecodeFails(damaged, "byte-order mark");
  expectDecodeFails(bytes + "x", "after the announced payload");
  damaged = bytes;
  poke(damaged, kLengthOffset, std::uint64_t{1} << 62);
  expectDecodeFails(damaged, "truncated");
}

TEST(StateFile, ContentsThatPassTheChecksumAreStillChecked) {
  const SimulationSnapshot saved = drivenSnapshot();
  // A state section whose particle count disagrees with its arrays.
  std::string bytes = encodeStateFile(saved);
  const std::size_t state_at = bytes.find("STAT");
  ASSERT_NE(state_at, std::string::npos);
  poke(bytes, state_at + 12, std::uint64_t{1} << 40);
  expectDecodeFails(withChecksum(bytes), "particles do not fit");
  // Options that are not YAML, or not valid options.
  SimulationSnapshot bad = saved;
  bad.options.substeps = -1;
  expectDecodeFails(encodeStateFile(bad), "substeps");
  // A grid that disagrees with the state's size.
  bad = saved;
  bad.options.rows = 11;
  expectDecodeFails(encodeStateFile(bad), "particles for a 11x10 grid");
  // Section tags out of place.
  bytes = encodeStateFile(saved);
  bytes[StateFileFormat::kHeaderBytes] = 'X';
  expectDecodeFails(withChecksum(bytes), "section 1");
}

TEST(StateFile, ErrorsQuoteNoFileContent) {
  SimulationSnapshot bad = drivenSnapshot();
  const std::string secret(500, 'S');
  bad.options.pins = {secret};
  SimulationSnapshot loaded;
  std::string error;
  EXPECT_FALSE(decodeStateFile(encodeStateFile(bad), &loaded, &error));
  EXPECT_EQ(error.find(secret.substr(0, 100)), std::string::npos) << "the message quotes the file: " << error;
  EXPECT_LT(error.size(), 300u) << error;

  const TempFolder folder;
  const std::string path = folder.file("not_a_state_file.yaml");
  std::ofstream(path) << "root:x:0:0:root:/root:/bin/bash\n";
  EXPECT_FALSE(readStateFile(path, &loaded, &error));
  EXPECT_NE(error.find("not a cloth_sim state file"), std::string::npos) << error;
  EXPECT_EQ(error.find("root:x"), std::string::npos) << error;
}

TEST(StateFile, MissingDirectoryOrOversizedFilesAreRefusedBeforeReading) {
  SimulationSnapshot loaded;
  std::string error;
  const TempFolder folder;
  EXPECT_FALSE(readStateFile(folder.file("absent.clothstate"), &loaded, &error));
  EXPECT_NE(error.find("no such file"), std::string::npos) << error;
  EXPECT_FALSE(readStateFile(folder.path(), &loaded, &error));
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
  EXPECT_FALSE(readStateFile("", &loaded, &error));
  // A sparse file one byte over the limit: refused from its size alone (reading it would take seconds).
  const std::string huge = folder.file("huge.clothstate");
  { std::ofstream(huge).put('C'); }
  fs::resize_file(huge, StateFileFormat::kMaxFileBytes + 1);
  EXPECT_FALSE(readStateFile(huge, &loaded, &error));
  EXPECT_NE(error.find("more than a state file of the largest grid"), std::string::npos) << error;
}

TEST(StateFile, TheLargestGridWithEveryParticlePinnedFitsUnderTheLimit) {
  // The worst case the size limit must allow: every particle pinned by index, each with its own pin
  // position (the longest options text), plus a full set of pin data. The size grows linearly with the
  // particles, so the per-particle cost is measured on 64 x 64 (with the largest grid's six-digit
  // indices) and must stay within the budget the limit allows per particle of the 512 x 512 grid.
  constexpr int kSide = 64;
  constexpr int kParticles = kSide * kSide;
  constexpr int kLargestIndex = OptionLimits::kMaxGridSide * OptionLimits::kMaxGridSide - 1;
  SimulationSnapshot worst;
  worst.options.rows = kSide;
  worst.options.cols = kSide;
  worst.options.pins.clear();
  const std::size_t without_pins = encodeStateFile(worst).size();
  for (int i = 0; i < kParticles; ++i) {
    worst.options.pins.push_back(std::to_string(kLargestIndex - i));
    worst.options.pin_positions_m.emplace_back(-123.45678901234567, 0.12345678901234567, -987.65432109876543);
  }
  worst.state.positions_m = Eigen::Matrix3Xd::Random(3, kParticles);
  worst.state.velocities_m_per_s = Eigen::Matrix3Xd::Random(3, kParticles);
  worst.inputs.pins.resize(kParticles);
  worst.inputs.pin_anchors_m = Eigen::Matrix3Xd::Random(3, kParticles);
  worst.inputs.pin_travel_m = Eigen::Matrix3Xd::Random(3, kParticles);
  worst.guard.calm_frames = 1;
  worst.guard.calm_anchor_m = Eigen::Matrix3Xd::Random(3, kParticles);
  const std::size_t size = encodeStateFile(worst).size();
  const double per_particle = static_cast<double>(size - without_pins) / kParticles;
  std::printf("[ size       ] every particle pinned: %.1f bytes per particle, budget %zu; fixed part %zu bytes\n",
              per_particle, StateFileFormat::kMaxBytesPerParticle, without_pins);
  EXPECT_LT(per_particle, static_cast<double>(StateFileFormat::kMaxBytesPerParticle));
  EXPECT_LT(without_pins, StateFileFormat::kFixedAllowanceBytes);
}

TEST(StateFile, SizesOfOrdinarySnapshots) {
  // Recorded in doc/STATE_FILE.md: the hanging scene at 128 x 128 and 512 x 512.
  for (const int side : {128, 512}) {
    SimulationSnapshot snapshot;
    snapshot.options = loadBuiltinScene("hanging");
    snapshot.options.rows = side;
    snapshot.options.cols = side;
    snapshot.state.positions_m.setZero(3, side * side);
    snapshot.state.velocities_m_per_s.setZero(3, side * side);
    snapshot.inputs.pins = {0, side - 1};
    snapshot.inputs.pin_anchors_m.setZero(3, 2);
    snapshot.inputs.pin_travel_m.setZero(3, 2);
    const std::size_t size = encodeStateFile(snapshot).size();
    std::printf("[ size       ] hanging %dx%d: %zu bytes\n", side, side, size);
    // Header, 10 section headers (tag + length), options text, state, inputs, guard memory (2 x int32),
    // grippers and frame colliders (a count of 0 each), the last frame's motion (a double), the calm
    // frames and the drive (an int32 and a uint64), the last frame's substeps (an int32), the calm frames'
    // largest step (a double) and anchor (a count of 0: the cloth is not calm).
    EXPECT_EQ(size, StateFileFormat::kHeaderBytes + 10 * 12 + sceneYaml(snapshot.options).size() +
                        (8 + 8 + 8 + 48 * static_cast<std::size_t>(side * side)) + (24 + 8 + 2 * 4 + 2 * 48 + 8) + 8 +
                        8 + 8 + 8 + (4 + 8) + 4 + (8 + 8));
  }
}

TEST(StateFile, WritingIsAtomicAndAnUnwritablePathFailsWithTheReason) {
  const SimulationSnapshot saved = drivenSnapshot();
  const TempFolder temp;
  const fs::path folder = temp.path();
  const std::string path = temp.file("atomic.clothstate");
  std::string error;
  ASSERT_TRUE(writeStateFile(path, saved, &error)) << error;
  ASSERT_TRUE(writeStateFile(path, saved, &error)) << "overwriting: " << error;
  const auto entries = [&folder] {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename().string());
    return names;
  };
  for (const std::string& name : entries()) {
    EXPECT_EQ(name.find(".tmp-"), std::string::npos) << "a temporary file was left behind: " << name;
  }

  // Through a regular file as if it were a folder, into a missing folder, onto a folder, nowhere.
  EXPECT_FALSE(writeStateFile(path + "/child.clothstate", saved, &error));
  EXPECT_NE(error.find("cannot create"), std::string::npos) << error;
  EXPECT_FALSE(writeStateFile(folder.string() + "/missing/x.clothstate", saved, &error));
  EXPECT_NE(error.find("No such file"), std::string::npos) << error;
  EXPECT_FALSE(writeStateFile(folder.string(), saved, &error));
  EXPECT_NE(error.find("is a directory"), std::string::npos) << error;
  EXPECT_FALSE(writeStateFile("", saved, &error));
  EXPECT_FALSE(writeStateFile("/proc/cloth_sim_state", saved, &error)) << "wrote into /proc";
  // A path whose lookup fails says why (an audit got "exists and is not a regular file" for both).
  const std::string too_long = folder.string() + "/" + std::string(300, 'x') + ".clothstate";
  EXPECT_FALSE(writeStateFile(too_long, saved, &error));
  EXPECT_NE(error.find(std::strerror(ENAMETOOLONG)), std::string::npos) << error;
  fs::create_symlink(folder / "loop_b", folder / "loop_a");
  fs::create_symlink(folder / "loop_a", folder / "loop_b");
  EXPECT_FALSE(writeStateFile((folder / "loop_a" / "x.clothstate").string(), saved, &error));
  EXPECT_NE(error.find(std::strerror(ELOOP)), std::string::npos) << error;

  // Another kind of file in the way is not replaced.
  const std::string other = folder.string() + "/notes.txt";
  std::ofstream(other) << "keep me\n";
  EXPECT_FALSE(writeStateFile(other, saved, &error));
  EXPECT_NE(error.find("not a cloth_sim state file: not replaced"), std::string::npos) << error;
  std::string kept;
  std::getline(std::ifstream(other), kept);
  EXPECT_EQ(kept, "keep me");

  // The good file is still whole after the failed saves.
  SimulationSnapshot loaded;
  ASSERT_TRUE(readStateFile(path, &loaded, &error)) << error;
  EXPECT_TRUE(sameSnapshot(saved, loaded));
}

}  // namespace
}  // namespace cloth_sim::core
