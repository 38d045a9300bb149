// cloth_bench: times one cloth scene, ROS-free, and prints the result as ONE JSON line on stdout (progress and
// errors go to stderr), so that scripts/bench.py can collect runs without parsing prose.
//
//   cloth_bench --scene hanging --rows 128 --cols 128 --integrator implicit_euler --substeps 1 --frames 100
//               --set structural_stiffness=20000
//   cloth_bench --bullet --rows 64 --cols 64 --substeps 10 --iterations 1 --frames 50   (built with Bullet only)
//
// The scene is built exactly as the node builds it: the scene file, then every override through the scene-file
// parser (applySceneYaml) and one validation (validateSceneOptions), so a key means here what it means there.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/scripted_fold.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/spatial_hash.h"
#include "cloth_sim/core/state.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/texture.h"

#include "accuracy_tool.h"
#include "bench_common.h"
#include "bench_stats.h"
#include "mode_validate.h"
#ifdef CLOTH_SIM_HAVE_BULLET
#include "bullet_cloth.h"
#endif

#include <Eigen/Core>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <exception>
#include <iostream>
#include <iterator>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#ifndef CLOTH_SIM_SCENES_DIR
#error "compile with -DCLOTH_SIM_SCENES_DIR=\"/path/to/config/scenes\""
#endif

namespace {

namespace core = cloth_sim::core;
using Clock = std::chrono::steady_clock;

// ---- constants -----------------------------------------------------------------------------------------------------

using cloth_sim::bench::kExitOk;
using cloth_sim::bench::kExitRunFailed;
using cloth_sim::bench::kExitUsage;  // also --bullet without Bullet

constexpr int kDefaultFrames = 100;
/// The most --frames, and the most --warmup: a million frames are 5.5 hours of a 50 Hz scene, and their sum
/// stays far inside an int (warm-up and timed frames are counted together; each timed frame keeps its time).
constexpr int kMaxBenchFrames = 1000000;
/// --capsules: each capsule's radius and core length, m, its gap to the cloth at rest and how far it
/// presses in (its surface goes from gap off the cloth to press - gap into it).
constexpr double kBenchCapsuleRadius_m = 0.03;
constexpr double kBenchCapsuleLength_m = 0.2;
constexpr double kBenchCapsuleGap_m = 0.01;
constexpr double kBenchCapsulePress_m = 0.02;

/// --grippers: how far each gripper circles (m) and how often (Hz, --capsules swing at the same rate), so
/// that its track, constraint and wrench are all exercised.
constexpr double kGripperCircle_m = 0.02;
constexpr double kGripperCircle_Hz = 1.0;

/// Frames run before timing starts: the first frames pay for allocations and cold caches.
constexpr int kDefaultWarmupFrames = 5;
constexpr int kDefaultBulletIterations = 1;
/// The most --iterations (Bullet's position iterations a substep): over 100 times the most its tables use (8).
constexpr int kMaxBulletIterations = 1000;
/// Bullet has no `auto`: a scene that asks for it runs Bullet at one substep per frame (what the scenes'
/// fixed count was before `auto`; --substeps sets it).
constexpr int kDefaultBulletSubsteps = 1;

/// The force-throughput loop runs at least this long and this many calls, so that one slow call (a page fault,
/// a thread pool starting) does not decide the figure.
constexpr double kMinThroughputSeconds = 0.3;
constexpr int kMinThroughputCalls = 10;

/// Any coordinate beyond this counts as not finite: far beyond every scene, far below overflow.
constexpr double kFiniteBound_m = 1e300;

using core::kMillisecondsPerSecond;
/// Significant digits of every number in the JSON line: timings are not more precise than this.
constexpr int kJsonDigits = 6;

constexpr const char* kStructuralStiffnessKey = "structural_stiffness";

constexpr const char* kUsage = R"(usage: cloth_bench [options]
Times a cloth scene and prints one JSON line on stdout.

  --scene NAME_OR_PATH   built-in scene name (resolved in --scenes-dir) or a .yaml path (default hanging)
  --scenes-dir DIR       where built-in scenes live (default: the build's config/scenes)
  --rows N, --cols N     grid size          (same as --set rows=N, --set cols=N)
  --integrator NAME      integration method (same as --set integrator=NAME)
  --substeps N           substeps per frame (same as --set substeps=N)
  --set KEY=VALUE        any scene key, parsed as in a scene file; repeatable. --rows, --cols, --integrator,
                         --substeps and --set apply in command-line order, after the scene file
  --frames N             timed frames (default 100, at most 1000000)
  --warmup N             frames run before timing starts (default 5, at most 1000000; not used with --bullet)
  --dynamic              cloth starts flat at the height of its top edge, its two top corners pinned where they
                         lie, and swings down: after --set, sets u_axis, v_axis, origin and pins, and clears
                         pin_positions, pin_travel_time and pin_motion_amplitude (refused where the outline
                         removes a top corner)
  --bullet               run Bullet's soft-body cloth instead (only in builds with Bullet); it takes rows,
                         cols, width, height, mass, frame_rate and substeps from the scene
  --iterations N         Bullet's position iterations per substep (default 1, at most 1000; --bullet only)
  --stop-above-strain X  end the run at the first frame whose structural strain exceeds X, that rolls back or
                         that is not finite: the setting has failed, and a diverging frame costs the guard up
                         to 15 times the substeps (not used with --bullet)
  --capsules N           add N capsule frame colliders (radius 3 cm, core 20 cm) spread across the cloth, each
                         lying along it and pressing 1 cm in and out of it at 1 Hz: the cost of robot links
                         (at most 256 with the scene's own)
  --grippers N           hold the cloth with N grippers (Simulation::attachGripper) along its bottom row, each
                         holding one particle and circling 2 cm at 1 Hz: the cost of grippers (0: none; at
                         most 16, and at most the row's particles)
  --fold                 fold the cloth in half with two hands as the `fold` scene's demo does (ScriptedFold,
                         scripted_fold.h): the cost of a fold, with self-collision as the scene sets it
  --help                 this text

Other modes (each with its own --help): --accuracy (speed against accuracy of every integrator and substep count
on a scene, with a recommendation), --stability-map (largest stable step of each integrator against stiffness and
mass, beside theory), --spatial (error of a grid against a finer grid of the same cloth), --validate (the textile
tests of doc/VALIDATION.md), --terms (cost and effect
of each force and collider term of a scene), --solver-sweep (implicit Euler's solver tolerance and iteration cap:
cost, CG iterations, converged share and error against a solve converged to 1e-9).

Strain, finiteness and rollbacks are checked on every simulated frame, warm-up included (Bullet's run checks
all its frames too); only the timings leave the warm-up out.
)";

// ---- command line --------------------------------------------------------------------------------------------------

using cloth_sim::bench::parseDouble;
using cloth_sim::bench::parseInt;
using cloth_sim::bench::SceneOverride;

/// Everything the command line says, parsed once.
struct BenchOptions {
  std::string scene = "hanging";
  std::string scenes_dir = CLOTH_SIM_SCENES_DIR;
  std::vector<SceneOverride> overrides;  ///< in command-line order
  int frames = kDefaultFrames;
  int warmup_frames = kDefaultWarmupFrames;
  bool dynamic = false;
  bool bullet = false;
  std::optional<int> bullet_iterations;  ///< set only by --iterations
  std::optional<double> stop_above_strain;  ///< set only by --stop-above-strain
  int grippers = 0;                         ///< --grippers N
  int capsules = 0;                         ///< --capsules N
  bool fold = false;                        ///< --fold
  bool help = false;
};

/// Parses a count flag's value into *out, which must lie in [minimum, maximum].
void parseCount(const std::string& flag, const std::string& text, int minimum, int maximum, int* out,
                std::vector<std::string>* errors) {
  const std::optional<int> value = parseInt(text);
  if (!value || *value < minimum || *value > maximum) {
    errors->push_back(flag + " " + text + ": expected an integer in [" + std::to_string(minimum) + ", " +
                      std::to_string(maximum) + "]");
    return;
  }
  *out = *value;
}

/// Flags that are shorthand for one scene key: {flag, key}.
constexpr std::pair<const char*, const char*> kSceneKeyFlags[] = {
    {"--rows", "rows"}, {"--cols", "cols"}, {"--integrator", "integrator"}, {"--substeps", "substeps"}};
/// The other flags that take a value.
constexpr const char* kValueFlags[] = {"--scene",      "--scenes-dir", "--set",
                                       "--frames",     "--warmup",     "--iterations",
                                       "--stop-above-strain", "--grippers", "--capsules"};

/// The scene key a shorthand flag stands for, or nullptr.
const char* sceneKeyOf(const std::string& flag) {
  for (const auto& [shorthand, key] : kSceneKeyFlags) {
    if (flag == shorthand) return key;
  }
  return nullptr;
}

bool takesValue(const std::string& flag) {
  return sceneKeyOf(flag) != nullptr ||
         std::any_of(std::begin(kValueFlags), std::end(kValueFlags), [&](const char* f) { return flag == f; });
}

/// Reads argv into *options; every problem goes to *errors.
void parseCommandLine(int argc, char** argv, BenchOptions* options, std::vector<std::string>* errors) {
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--help" || flag == "-h") {
      options->help = true;
      continue;
    }
    if (flag == "--dynamic") {
      options->dynamic = true;
      continue;
    }
    if (flag == "--bullet") {
      options->bullet = true;
      continue;
    }
    if (flag == "--fold") {
      options->fold = true;
      continue;
    }
    if (!takesValue(flag)) {
      errors->push_back("unknown option '" + flag + "' (see --help)");
      continue;
    }
    if (i + 1 >= argc) {
      errors->push_back(flag + ": missing value");
      break;
    }
    const std::string value = argv[++i];
    if (flag == "--scene") {
      options->scene = value;
    } else if (flag == "--scenes-dir") {
      options->scenes_dir = value;
    } else if (flag == "--set") {
      cloth_sim::bench::parseSceneSetting(value, &options->overrides, errors);
    } else if (flag == "--frames") {
      parseCount(flag, value, 1, kMaxBenchFrames, &options->frames, errors);
    } else if (flag == "--capsules") {
      // Bounded here, before the scene is built with them (2e9 of them ran out of memory there).
      parseCount(flag, value, 0, static_cast<int>(core::OptionLimits::kMaxFrameColliders), &options->capsules, errors);
    } else if (flag == "--grippers") {
      parseCount(flag, value, 0, static_cast<int>(core::Simulation::kMaxGrippers), &options->grippers, errors);
    } else if (flag == "--warmup") {
      parseCount(flag, value, 0, kMaxBenchFrames, &options->warmup_frames, errors);
    } else if (flag == "--iterations") {
      int iterations = 0;
      parseCount(flag, value, 1, kMaxBulletIterations, &iterations, errors);
      options->bullet_iterations = iterations;
    } else if (flag == "--stop-above-strain") {
      const std::optional<double> strain = parseDouble(value);
      if (!strain || *strain <= 0) errors->push_back(flag + " " + value + ": expected a number > 0");
      options->stop_above_strain = strain;
    } else {
      options->overrides.push_back({flag, sceneKeyOf(flag), value});
    }
  }

  if (options->grippers > 0 && options->bullet) errors->push_back("--grippers: Bullet's run has no grippers");
  if (options->capsules > 0 && options->bullet) errors->push_back("--capsules: Bullet's run has no frame colliders");
  if (options->fold && options->bullet) errors->push_back("--fold: Bullet's run has no hands");
  if (options->stop_above_strain && options->bullet) {
    errors->push_back("--stop-above-strain: Bullet's run cannot stop early (it checks its strain after the run)");
  }
  if (options->bullet_iterations && !options->bullet) {
    errors->push_back(
        "--iterations is Bullet's position iterations and needs --bullet (ours: --set solver_max_iterations=N)");
  }
}

// ---- scene ---------------------------------------------------------------------------------------------------------

/// Whether the scene's texture decodes, as cloth_node decodes it when it builds the cloth (sceneVertexColors),
/// refusing the scene where it does not. The scene-file loader checks only that the file is there and regular,
/// and a texture from --set not even that. False with the image reader's reason ("texture PATH: unknown image
/// type") in *errors. Call on a validated scene.
bool textureDecodes(const core::SceneOptions& scene, std::vector<std::string>* errors) {
  if (scene.texture.empty()) return true;
  // The grid's uv depend on rows and cols alone: the node samples the image at the same points.
  const core::ClothGrid grid = core::buildClothGrid(scene.rows, scene.cols, scene.width_m, scene.height_m,
                                                    scene.origin_m, scene.u_axis, scene.v_axis);
  Eigen::Matrix3Xf colors;
  std::string error;
  if (core::sceneVertexColors(scene.texture, grid.uv, &colors, &error)) return true;
  errors->push_back(error);
  return false;
}

/// The scene file, then the overrides in order, then --dynamic; validated once at the end, its texture
/// decoded. False with every problem in *errors.
bool buildScene(const BenchOptions& options, core::SceneOptions* scene, std::vector<std::string>* errors) {
  if (!cloth_sim::bench::loadSceneWithOverrides(options.scene, options.scenes_dir, options.overrides, scene, errors)) {
    return false;
  }
  if (options.dynamic) {
    cloth_sim::bench::makeDynamic(scene);
    const std::string problem = cloth_sim::bench::dynamicPinsProblem(*scene);
    if (!problem.empty()) {
      errors->push_back(problem);
      return false;
    }
  }
  // One particle of the bottom row each (attachBenchGrippers): a usage error, not a failed run.
  if (options.grippers > scene->cols) {
    errors->push_back("--grippers " + std::to_string(options.grippers) + ": the bottom row holds " +
                      std::to_string(scene->cols) + " particles, one for each gripper");
    return false;
  }
  for (int k = 0; k < options.capsules; ++k) {
    core::FrameCollider capsule;
    capsule.frame = "bench_capsule_" + std::to_string(k);
    capsule.shape = core::ShapeKind::kCapsule;
    capsule.radius_m = kBenchCapsuleRadius_m;
    capsule.length_m = kBenchCapsuleLength_m;
    scene->colliders.frames.push_back(capsule);
  }
  return cloth_sim::bench::validateInto(*scene, errors) && textureDecodes(*scene, errors);
}

// ---- measurements --------------------------------------------------------------------------------------------------

/// What one run measured, ours or Bullet's; what a side cannot measure stays empty (JSON null).
struct BenchResult {
  std::string side;
  std::string integrator;
  std::optional<int> iterations;  ///< Bullet's position iterations
  std::optional<double> ms_per_frame, p50_ms, p99_ms;  ///< empty when no frame was timed
  std::optional<int> frames_timed;  ///< empty: not known (Bullet's run that blew up)
  std::string stopped;  ///< why the run ended before its frames (--stop-above-strain); empty: it ran them all
  double max_strain = 0;
  bool finite = true;
  int guard_recomputed = 0;
  int rolled_back = 0;
  std::optional<double> solver_iterations;  ///< mean CG iterations per integrator step
  std::optional<double> solver_converged_fraction;  ///< of the timed frames, those whose every solve converged
  std::optional<double> springs_per_s;
  std::optional<long long> springs;  ///< springs (ours) or links (Bullet) in the cloth
  double rss_mb = 0;
  int threads = 1;
  /// With self-collision: pairs pushed apart per timed frame, and the broad phase's share of a frame's
  /// time (one SweptPairFinder::find over the frame's motion, timed apart, times the two finds per substep).
  std::optional<double> self_contacts_per_frame;
  std::optional<double> broad_phase_share;
  double stiffness = 0;  ///< ours: structural N/m; Bullet: link stiffness m_kLST in (0, 1]
};

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count() * kMillisecondsPerSecond;
}

/// Springs evaluated per second by one force evaluation at the current state (the kernel the integrators spend
/// their time in, measured without the solver around it).
double springThroughput(core::Simulation& sim) {
  const Eigen::Matrix3Xd x = sim.state().positions_m;
  const Eigen::Matrix3Xd v = sim.state().velocities_m_per_s;
  const double time_s = sim.state().time_s;
  Eigen::Matrix3Xd forces_N;
  sim.forceModel().forces(x, v, time_s, forces_N);  // sizes the scratch outside the timed loop

  long long calls = 0;
  const Clock::time_point start = Clock::now();
  double seconds = 0;
  while (calls < kMinThroughputCalls || seconds < kMinThroughputSeconds) {
    sim.forceModel().forces(x, v, time_s, forces_N);
    ++calls;
    seconds = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return static_cast<double>(calls) * static_cast<double>(sim.forceModel().springCount()) / seconds;
}

/// Why a run with --stop-above-strain should end after this frame; empty: carry on.
std::string stopReason(const BenchOptions& options, const core::FrameReport& report, bool finite) {
  if (!options.stop_above_strain) return "";
  if (!finite) return "not finite";
  if (!report.stable) return "rolled back";
  if (report.max_strain <= *options.stop_above_strain) return "";
  std::ostringstream reason;
  reason << "strain " << report.max_strain << " > " << *options.stop_above_strain;
  return reason.str();
}

/// Where --capsules' capsule k of `count` is at time_s: lying along the cloth's u axis over its rest
/// surface at an even spread over its diagonal, its surface moving between 1 cm off the cloth and 1 cm
/// into it along the surface's normal at kGripperCircle_Hz (a link brushing the cloth, every frame checked
/// against every particle).
core::Pose benchCapsulePose(const core::Simulation& sim, int k, int count, double time_s) {
  const core::ClothGrid& grid = sim.grid();
  const int rows = grid.rows;
  const int cols = grid.cols;
  const double share = (k + 1.0) / (count + 1.0);
  const int particle = static_cast<int>(share * (rows - 1)) * cols + static_cast<int>(share * (cols - 1));
  const Eigen::Vector3d u = sim.options().u_axis.normalized();
  const Eigen::Vector3d normal = u.cross(sim.options().v_axis).normalized();
  const double press_m = kBenchCapsulePress_m * 0.5 * (1.0 - std::cos(core::kTwoPi * kGripperCircle_Hz * time_s));
  core::Pose pose;
  pose.position_m = grid.rest_positions_m.col(particle) + (kBenchCapsuleRadius_m + kBenchCapsuleGap_m - press_m) * normal;
  pose.orientation = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), u);
  return pose;
}

/// A request the options allow but this scene cannot take (a gripper on a pinned particle): the caller's
/// error, exit 2, not a failed run.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Attaches `count` grippers along the bottom row (free in every built-in scene's pinning), one particle
/// each, spread evenly. Returns their starting poses; UsageError where the scene pins or removes one.
std::vector<core::Pose> attachBenchGrippers(core::Simulation& sim, int count) {
  std::vector<core::Pose> poses;
  const int cols = sim.grid().cols;
  const int bottom_row = (sim.grid().rows - 1) * cols;
  for (int k = 0; k < count; ++k) {
    const int particle = bottom_row + (count == 1 ? cols / 2 : k * (cols - 1) / (count - 1));
    core::GripperRequest request;
    request.id = static_cast<std::uint32_t>(k);
    request.frame = "bench_" + std::to_string(k);
    request.pose.position_m = sim.state().positions_m.col(particle);
    request.particles = {particle};
    std::vector<int> held;
    std::string error;
    if (!sim.attachGripper(request, &held, &error)) throw UsageError("--grippers: " + error);
    poses.push_back(request.pose);
  }
  return poses;
}

void moveBenchGrippers(core::Simulation& sim, const std::vector<core::Pose>& homes) {
  const double phase = core::kTwoPi * kGripperCircle_Hz * (sim.state().time_s + sim.options().frameDuration_s());
  for (std::size_t k = 0; k < homes.size(); ++k) {
    core::Pose pose = homes[k];
    pose.position_m += kGripperCircle_m * Eigen::Vector3d(std::cos(phase) - 1.0, std::sin(phase), 0.0);
    std::string error;
    sim.moveGripper(static_cast<std::uint32_t>(k), pose, &error);
  }
}

/// Runs warm-up and timed frames of our simulator.
BenchResult runOurs(const BenchOptions& options, const core::SceneOptions& scene) {
  core::Simulation sim(scene);
  const std::vector<core::Pose> gripper_homes = attachBenchGrippers(sim, options.grippers);
  const core::ScriptedFold fold;
  // A hand the cloth cannot give a corner to would fold nothing, and the run would time that.
  const std::string fold_problem = options.fold ? fold.holdProblem(sim.grid()) : "";
  if (!fold_problem.empty()) throw UsageError("--fold: " + fold_problem);
  BenchResult result;
  result.side = "cloth_sim";
  result.integrator = core::integratorName(scene.integrator);
  // A material scene's springs follow from its material and grid (resolveMaterial), not from the
  // SceneOptions defaults it leaves in place.
  result.stiffness =
      core::resolveMaterial(scene).springs[static_cast<int>(core::SpringKind::kStructural)].stiffness_N_per_m;
  result.max_strain = sim.maxStructuralStrain();

  std::vector<double> frame_ms;
  frame_ms.reserve(static_cast<std::size_t>(options.frames));
  long long solver_iterations = 0, integrator_steps = 0;
  int converged_frames = 0;
  std::string fold_error;
  const bool self_colliding = scene.self_collision.enabled;
  core::SweptPairFinder finder;
  std::vector<std::pair<int, int>> pairs;
  const double thickness_m = core::selfCollisionThickness_m(scene.self_collision, sim.grid());
  double self_contacts = 0.0;
  double broad_phase_ms = 0.0;
  const int total_frames = options.warmup_frames + options.frames;
  for (int frame = 0; frame < total_frames; ++frame) {
    const Eigen::Matrix3Xd frame_start_m = self_colliding ? sim.state().positions_m : Eigen::Matrix3Xd();
    const Clock::time_point start = Clock::now();
    if (options.fold && !fold.drive(sim, &fold_error)) throw std::runtime_error("--fold: " + fold_error);
    moveBenchGrippers(sim, gripper_homes);
    for (int k = 0; k < options.capsules; ++k) {
      std::string error;
      sim.moveFrameCollider(static_cast<std::size_t>(k),
                            benchCapsulePose(sim, k, options.capsules, sim.state().time_s + sim.options().frameDuration_s()),
                            &error);
    }
    const core::FrameReport report = sim.advanceFrame();
    const double ms = millisecondsSince(start);

    // Quality counts every frame, warm-up included: a blow-up in the first frames is still a blow-up.
    const bool finite = core::isFiniteAndBounded(sim.state(), kFiniteBound_m);
    result.max_strain = std::max(result.max_strain, report.max_strain);
    result.finite = result.finite && finite;
    if (report.recomputed) ++result.guard_recomputed;
    if (!report.stable) ++result.rolled_back;
    if (frame >= options.warmup_frames) {
      frame_ms.push_back(ms);
      solver_iterations += report.steps.solver_iterations;
      integrator_steps += report.substeps_used;
      if (report.steps.converged) ++converged_frames;
      if (self_colliding) {
        self_contacts += report.self_collision.contacts;
        const Clock::time_point find_start = Clock::now();
        const Eigen::Matrix3Xd& rest = sim.grid().rest_positions_m;
        const double exempt_m = core::SelfCollision::kExemptRestThicknesses * thickness_m;
        finder.find(frame_start_m, sim.state().positions_m, thickness_m,
                    [&](int i, int j) { return (rest.col(i) - rest.col(j)).norm() > exempt_m; }, &pairs);
        constexpr int kFindsPerSubstep = 2;  // the response's and the fail-safe's
        broad_phase_ms += kFindsPerSubstep * report.substeps_used * millisecondsSince(find_start);
      }
    }
    result.stopped = stopReason(options, report, finite);
    if (!result.stopped.empty()) break;
  }

  if (self_colliding && !frame_ms.empty()) {
    double total_ms = 0.0;
    for (const double ms : frame_ms) total_ms += ms;
    result.self_contacts_per_frame = self_contacts / static_cast<double>(frame_ms.size());
    result.broad_phase_share = total_ms > 0.0 ? broad_phase_ms / total_ms : 0.0;
  }
  const cloth_sim::bench::FrameTimings timings = cloth_sim::bench::summarizeFrameTimes(frame_ms);
  result.ms_per_frame = timings.mean_ms;
  result.p50_ms = timings.p50_ms;
  result.p99_ms = timings.p99_ms;
  result.frames_timed = static_cast<int>(frame_ms.size());
  if (!frame_ms.empty()) {
    result.solver_iterations =
        integrator_steps > 0 ? static_cast<double>(solver_iterations) / static_cast<double>(integrator_steps) : 0.0;
    result.solver_converged_fraction = static_cast<double>(converged_frames) / static_cast<double>(frame_ms.size());
  }
  result.springs_per_s = springThroughput(sim);
  result.springs = static_cast<long long>(sim.forceModel().springCount());
  result.threads = sim.forceModel().threads();
  result.rss_mb = cloth_sim::bench::peakRssMb();
  return result;
}

#ifdef CLOTH_SIM_HAVE_BULLET
/// Bullet's cloth on the scene's grid, size, mass and frame rate (its pose and pins are fixed: bullet_cloth.h).
BenchResult runBullet(const BenchOptions& options, const core::SceneOptions& scene) {
  cloth_sim::bench::BulletClothSetup setup;
  setup.rows = scene.rows;
  setup.cols = scene.cols;
  setup.width_m = scene.width_m;
  setup.height_m = scene.height_m;
  setup.mass_kg = scene.mass_kg;
  setup.substeps = scene.substeps;
  setup.position_iterations = options.bullet_iterations.value_or(kDefaultBulletIterations);
  setup.frames = options.frames;
  setup.frame_s = scene.frameDuration_s();
  setup.dynamic = options.dynamic;
  const cloth_sim::bench::BulletClothResult run = cloth_sim::bench::runBulletCloth(setup);

  BenchResult result;
  result.side = "bullet";
  result.integrator = "bullet_pbd";
  result.iterations = setup.position_iterations;
  result.ms_per_frame = run.ms_per_frame;
  result.p50_ms = run.p50_ms;
  result.p99_ms = run.p99_ms;
  result.max_strain = run.max_strain;
  result.finite = run.finite;
  // Bullet stops at the first frame that is not finite; its timings then cover fewer frames than asked for.
  if (run.finite) {
    result.frames_timed = setup.frames;
  } else {
    result.stopped = "not finite";
  }
  result.springs = run.links;
  result.rss_mb = run.rss_mb;
  result.stiffness = setup.stretch_stiffness;
  return result;  // Bullet has no guard, no CG solve and no separate force kernel: those stay null
}
#endif

// ---- output --------------------------------------------------------------------------------------------------------

/// A flat JSON object on one line, written by hand: the tool needs no JSON library for a dozen scalar keys.
class JsonLine {
 public:
  JsonLine& add(const std::string& key, const std::string& value) { return raw(key, quoted(value)); }
  JsonLine& add(const std::string& key, const char* value) { return add(key, std::string(value)); }
  JsonLine& add(const std::string& key, bool value) { return raw(key, value ? "true" : "false"); }
  JsonLine& add(const std::string& key, int value) { return raw(key, std::to_string(value)); }
  JsonLine& add(const std::string& key, long long value) { return raw(key, std::to_string(value)); }
  JsonLine& add(const std::string& key, double value) { return raw(key, number(value)); }
  template <typename T>
  JsonLine& add(const std::string& key, const std::optional<T>& value) {
    return value ? add(key, *value) : raw(key, "null");
  }
  std::string str() const { return "{" + body_ + "}"; }

 private:
  JsonLine& raw(const std::string& key, const std::string& json_value) {
    if (!body_.empty()) body_ += ", ";
    body_ += quoted(key) + ": " + json_value;
    return *this;
  }

  /// JSON has no NaN or infinity; a quantity that is not a number is null.
  static std::string number(double value) {
    if (!std::isfinite(value)) return "null";
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%.*g", kJsonDigits, value);
    return buffer;
  }

  static std::string quoted(const std::string& text) { return cloth_sim::bench::jsonQuoted(text); }

  std::string body_;
};

std::string toJson(const BenchOptions& options, const core::SceneOptions& scene, const BenchResult& r) {
  const double frame_ms = scene.frameDuration_s() * kMillisecondsPerSecond;
  const std::optional<double> realtime_factor =
      r.ms_per_frame && *r.ms_per_frame > 0 ? std::optional<double>(frame_ms / *r.ms_per_frame) : std::nullopt;
  JsonLine json;
  json.add("scene", scene.name)
      .add("side", r.side)
      .add("rows", scene.rows)
      .add("cols", scene.cols)
      .add("integrator", r.integrator);
  if (scene.autoSubsteps()) {
    json.add("substeps", core::kAutoSubstepsName);
  } else {
    json.add("substeps", scene.substeps);
  }
  json.add("iterations", r.iterations)
      .add("stiffness", r.stiffness)
      .add("dynamic", options.dynamic)
      .add("grippers", options.grippers)
      .add("capsules", options.capsules)
      .add("fold", options.fold)
      .add("self_collision", scene.self_collision.enabled)
      .add("self_contacts_per_frame", r.self_contacts_per_frame)
      .add("broad_phase_share", r.broad_phase_share)
      .add("frames", options.frames)
      .add("warmup", options.bullet ? 0 : options.warmup_frames)
      .add("frames_timed", r.frames_timed)
      .add("stopped", r.stopped.empty() ? std::optional<std::string>() : std::optional<std::string>(r.stopped))
      .add("ms_per_frame", r.ms_per_frame)
      .add("p50_ms", r.p50_ms)
      .add("p99_ms", r.p99_ms)
      .add("realtime_factor", realtime_factor)
      .add("max_strain", r.max_strain)
      .add("finite", r.finite)
      .add("guard_recomputed", r.guard_recomputed)
      .add("rolled_back", r.rolled_back)
      .add("solver_iterations", r.solver_iterations)
      .add("solver_converged_fraction", r.solver_converged_fraction)
      .add("springs", r.springs)
      .add("springs_per_s", r.springs_per_s)
      .add("rss_mb", r.rss_mb)
      .add("threads", r.threads);
  return json.str();
}

void printErrors(const std::vector<std::string>& errors) {
  for (const std::string& error : errors) std::cerr << "cloth_bench: " << error << "\n";
}

std::string describeRun(const BenchOptions& options, const core::SceneOptions& scene) {
  std::ostringstream out;
  out << "cloth_bench: " << (options.bullet ? "bullet" : "cloth_sim") << " " << scene.name << " " << scene.rows << "x"
      << scene.cols << (options.bullet ? "" : std::string(" ") + core::integratorName(scene.integrator))
      << " substeps " << (scene.autoSubsteps() ? std::string(core::kAutoSubstepsName) : std::to_string(scene.substeps))
      << (options.dynamic ? " dynamic" : "") << ", " << options.frames
      << " frames";
  return out.str();
}

}  // namespace

int main(int argc, char** argv) {
  // --accuracy, --stability-map, --spatial and --terms are modes of their own, with their own flags.
  if (cloth_sim::bench::isAccuracyToolCommand(argc, argv)) {
    return cloth_sim::bench::runAccuracyTool(argc, argv, CLOTH_SIM_SCENES_DIR);
  }
  if (cloth_sim::bench::isValidateCommand(argc, argv)) {
    return cloth_sim::bench::runValidate(argc, argv, CLOTH_SIM_SCENES_DIR);
  }
  BenchOptions options;
  std::vector<std::string> errors;
  parseCommandLine(argc, argv, &options, &errors);
  if (options.help) {
    std::cout << kUsage;  // asked for, so on stdout (a run never prints it)
    return errors.empty() ? kExitOk : kExitUsage;
  }
#ifndef CLOTH_SIM_HAVE_BULLET
  if (options.bullet) {
    errors.push_back("--bullet: this cloth_bench was built without Bullet (install libbullet-dev and rebuild)");
  }
#endif
  if (!errors.empty()) {
    printErrors(errors);
    return kExitUsage;
  }

  core::SceneOptions scene;
  if (!buildScene(options, &scene, &errors)) {
    printErrors(errors);
    return kExitUsage;
  }
  if (options.bullet && scene.autoSubsteps()) scene.substeps = kDefaultBulletSubsteps;

  std::cerr << describeRun(options, scene) << "\n";
  try {
    BenchResult result;
#ifdef CLOTH_SIM_HAVE_BULLET
    result = options.bullet ? runBullet(options, scene) : runOurs(options, scene);
#else
    result = runOurs(options, scene);
#endif
    std::cout << toJson(options, scene, result) << std::endl;
  } catch (const UsageError& e) {
    std::cerr << "cloth_bench: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "cloth_bench: run failed: " << e.what() << "\n";
    return kExitRunFailed;
  }
  return kExitOk;
}
