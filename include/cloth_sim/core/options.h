// One options struct for a whole scene: built from a scene file and parameters, validated once, then
// handed to Simulation. Field names match the scene-file keys and the node's private parameters.
#pragma once

#include "cloth_sim/core/camera.h"
#include "cloth_sim/core/contact.h"
#include "cloth_sim/core/curvature_bending.h"
#include "cloth_sim/core/forces.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/material.h"
#include "cloth_sim/core/self_collision.h"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// Ranges that validation enforces (and the docs quote).
struct OptionLimits {
  static constexpr int kMinGridSide = 2;
  static constexpr int kMaxGridSide = 512;
  static constexpr int kMaxSubsteps = 10000;
  /// The node advances, publishes and updates its 1 Hz diagnostics from one timer per frame: a longer
  /// frame would leave them silent (and 1e-10 Hz overflowed ros::Duration).
  static constexpr double kMinFrameRateHz = 1.0;
  static constexpr double kMaxFrameRateHz = 1000.0;
  static constexpr double kMaxStiffnessN_per_m = 1e7;
  static constexpr double kMaxDampingN_s_per_m = 1e4;
  static constexpr double kMaxWindSpeed_m_per_s = 100.0;  ///< magnitude of the mean wind vector
  static constexpr double kMaxClothSide_m = 100.0;
  static constexpr double kMaxMass_kg = 1e4;
  /// Lightest cloth, kg (1 mg: a 1 cm square of the lightest silk). The guard measures each frame's
  /// energy against a scale made of the cloth's weight and motion, and the springs' energy is only
  /// resolved to the rounding of the coordinates (k (eps x)^2 per spring): a cloth lighter than about
  /// 1e-27 kg sits below that rounding, and every frame of it was rolled back (`mass: 1e-50` froze for
  /// good). 1 mg keeps 20 orders of magnitude from there at every stiffness the options accept.
  static constexpr double kMinMass_kg = 1e-6;
  /// Most colliders on tf frames (frame_colliders plus a URDF's links).
  static constexpr std::size_t kMaxFrameColliders = 256;
  /// Largest roll, pitch or yaw a frame collider's offset may give, rad (a few turns either way).
  static constexpr double kMaxAngle_rad = 100.0;
  static constexpr double kMaxCoordinate_m = 1000.0;        ///< cloth, colliders and pin motion
  static constexpr double kMaxAcceleration_m_per_s2 = 1000.0;  ///< gravity
  static constexpr double kMaxColliderSpeed_m_per_s = 100.0;  ///< peak: drift plus swing |A| 2 pi / T
  /// Peak speed of a pin: its motion |A| 2 pi / T, and its travel to pin_positions (1.5 d / travel time,
  /// kSmoothstepPeakRate).
  /// A pin at 6e303 m/s (pin_motion_period 1e-300) made the kinetic energy infinite.
  static constexpr double kMaxPinSpeed_m_per_s = 100.0;
  static constexpr double kMaxPeriod_s = 1e4;               ///< gusts, pin motion, sphere swings
  static constexpr double kMaxWindCoefficient = 10.0;       ///< paper coefficient, N s/m, and drag C_d
  static constexpr double kMaxAirDensity_kg_per_m3 = 10.0;
  static constexpr double kMaxGustAmplitude = 10.0;          ///< relative to the mean wind
  static constexpr double kMaxContactDepth_m = 1.0;
  static constexpr double kMaxFriction = 10.0;
  /// Fastest `sleep_speed`, m/s: a cloth visibly moving (1 cm/s is 0.2 mm a frame) must not freeze.
  static constexpr double kMaxSleepSpeed_m_per_s = 0.01;
  /// Thickest self_collision_thickness, m (0 is its default: from the grid spacing).
  static constexpr double kMaxSelfCollisionThickness_m = 1.0;
  static constexpr double kMinSolverTolerance = 1e-14;  ///< below rounding the solve cannot converge
  static constexpr double kMaxSolverTolerance = 1.0;    ///< a relative residual of 1: no iteration needed
  static constexpr int kMaxSolverIterations = 10000;
  static constexpr int kMaxThreads = 64;
  /// Longest text a file or parameter can set, characters (Linux's PATH_MAX): the scene name, the texture
  /// path, each pin selector, the node's frame ids and the paths a service is given. A state file once
  /// carried a 60 MB scene name into every diagnostics message.
  static constexpr std::size_t kMaxTextChars = 4096;
  /// Most pin selectors a scene may list: one per particle of the largest grid.
  static constexpr std::size_t kMaxPinSelectors = static_cast<std::size_t>(kMaxGridSide) * kMaxGridSide;
  /// Latest simulated time, s (31.7 years; a state file with more is refused, and a simulation stops
  /// here): at 1e9 s a double still resolves 1.2e-7 s, so the shortest frame (1 / kMaxFrameRateHz) still
  /// advances time by itself, to a part in 1e4. A file with time 1e300 s froze sim_time (1e300 + 0.02
  /// is 1e300).
  static constexpr double kMaxSimTime_s = 1e9;
  /// Largest frame counter: as many frames as kMaxSimTime_s holds at the highest frame rate (1e12), far
  /// below 2^64, so the counter cannot wrap.
  static constexpr std::uint64_t kMaxFrame = static_cast<std::uint64_t>(kMaxSimTime_s * kMaxFrameRateHz);
};

/// Empty when `value` is at most OptionLimits::kMaxTextChars long; else the problem, naming `field` and
/// the length (not the text).
std::string textLengthProblem(const std::string& field, const std::string& value);

/// Empty when a wind velocity (m/s) may blow: finite, magnitude at most OptionLimits::kMaxWindSpeed_m_per_s.
/// Else "magnitude M m/s: must be finite and at most 100 m/s": one rule for a scene's wind, ~wind, the
/// reconfigure sliders and a state file's wind (each names its own source before it).
std::string windVelocityProblem(const Eigen::Vector3d& wind_m_per_s);

/// The value of the `substeps` key (scene files, parameters) that asks for SceneOptions::kAutoSubsteps.
inline constexpr const char* kAutoSubstepsName = "auto";

/// A non-rectangular cloth (issue 17): the particles of the rows x cols grid inside this outline, in the
/// cloth's own (u, v) metres (particle (r, c) sits at (c du, r dv)), with their springs and triangles.
struct OutlineOptions {
  enum class Shape { kNone, kCircle, kPolygon };
  Shape shape = Shape::kNone;
  Eigen::Vector2d center_m = Eigen::Vector2d::Zero();  ///< kCircle
  double radius_m = 0.0;                               ///< kCircle
  std::vector<Eigen::Vector2d> vertices_m;             ///< kPolygon, in order (either way round)
};

struct SceneOptions {
  std::string name = "hanging";

  // Grid, world frame, metres: particle (r, c) at origin + c du u_axis + r dv v_axis.
  int rows = 20;
  int cols = 20;
  double width_m = 1.0;
  double height_m = 1.0;
  Eigen::Vector3d origin_m{-0.5, 0.0, 1.5};
  Eigen::Vector3d u_axis{1.0, 0.0, 0.0};
  Eigen::Vector3d v_axis{0.0, 0.0, -1.0};

  double mass_kg = 0.5;  ///< whole cloth, shared equally by the particles (by area with a material)
  Eigen::Vector3d gravity_m_per_s2{0.0, 0.0, -9.81};

  /// Indexed by SpringKind.
  std::array<SpringOptions, kSpringKindCount> springs{{{true, 1000.0, 0.5}, {true, 200.0, 0.1}, {true, 40.0, 0.02}}};
  double air_damping_N_s_per_m = 0.002;  ///< per particle, paper §3.2 (see airDampingPerParticle)

  /// A fabric in physical units (issue 17). With one, `mass` and the springs' constants are derived
  /// from it for this grid (resolveMaterial), and air damping and the paper's wind act per area; without
  /// one (the paper's scenes), they are the per-spring and per-particle values as given.
  bool has_material = false;
  MaterialOptions material;
  /// Bend springs (the paper) or the curvature energy (needs a material).
  BendModel bend_model = BendModel::kSprings;
  /// Linear compressed springs (the paper's), or capped at the fabric's buckling load (needs a material).
  CompressionModel compression_model = CompressionModel::kLinear;
  /// The cloth's outline; none: the whole rectangle.
  OutlineOptions outline;
  bool wind_enabled = false;
  WindOptions wind;

  /// Pinned particles: "top_left", "top_right", "bottom_left", "bottom_right", "top_edge", "bottom_edge",
  /// "left_edge", "right_edge", or a particle index as a decimal string.
  std::vector<std::string> pins{"top_left", "top_right"};
  /// Where the pins hang (world frame, m), one per pinned particle in increasing particle index; empty:
  /// each where its particle starts. Hooks apart from the rest grid let a cloth sag and fold between
  /// them (the `drape` scene hangs a 1 m cloth from corners 0.6 m apart).
  std::vector<Eigen::Vector3d> pin_positions_m;
  /// Seconds the pins take to travel from where their particles start to pin_positions (a smooth start
  /// and stop, as a hand would carry them); 0: they are there at once.
  double pin_travel_time_s = 0.0;
  /// Pins move by A sin(2 pi t / T) (a curtain rail, a waved flag pole); zero amplitude: fixed.
  Eigen::Vector3d pin_motion_amplitude_m = Eigen::Vector3d::Zero();
  double pin_motion_period_s = 1.0;

  ColliderSet colliders;
  ContactOptions contact;
  /// Off by default: a scene pays nothing for layers it does not have (issue 15).
  SelfCollisionOptions self_collision;

  double grasp_stiffness_N_per_m = 50.0;  ///< used when a grasp asks for 0
  double grasp_damping_N_s_per_m = 0.5;

  /// `substeps: auto`: the guard picks the substeps of each frame from the scene's highest frequency and
  /// the integrator's stability region (StabilityGuard).
  static constexpr int kAutoSubsteps = 0;

  /// Implicit Euler with `auto` substeps (one step per frame while its solve converges): it cannot
  /// diverge at any grid size and stiffness the options accept, though at their extremes together
  /// (512 x 512, springs and a grasp of 1e7 N/m) its solve may stop unconverged at solver_max_iterations
  /// and the guard reset the scene (issue 18). doc/ACCURACY.md says when an explicit method is the
  /// better trade.
  IntegratorKind integrator = IntegratorKind::kImplicitEuler;
  int substeps = kAutoSubsteps;  ///< per frame, or kAutoSubsteps
  /// A frame the guard rejects is recomputed with 2x, 4x, 8x the substeps before it is rolled back;
  /// false: computed once (fixed-step accuracy runs, tests), rejected frames still rolled back and reported.
  bool guard_retries = true;
  /// A cloth at rest is no longer computed (it sleeps, as PhysX's and NvCloth's cloths do) once for
  /// kSleepAfter_s in a row no particle has got further than this, m/s, times kSleepAfter_s from where it
  /// was when they began (Simulation::sleepAllowance_m), while nothing drove it: every hook,
  /// sphere, gripper and frame collider held still, the wind had no gusts and no input changed. Anything
  /// that drives it again wakes it before the frame is computed. 0: never sleeps.
  double sleep_speed_m_per_s = kDefaultSleepSpeed_m_per_s;
  /// 0.1 mm/s: 50 um over kSleepAfter_s, far below what a picture shows and 10x below the creep the
  /// self-collision tests allow a resting towel (1 mm/s). A folded 64 x 64 towel comes to an exact rest
  /// (1e-15 m/s) about 1 s after it is let go, or, folded by the node's hands (a frame late), into a
  /// limit cycle of 13 um a frame that stays within 50 um; a cloth still creeping faster keeps being
  /// computed.
  static constexpr double kDefaultSleepSpeed_m_per_s = 1e-4;
  /// How long the cloth must stay within sleep_speed times this of where it was when it began to, before
  /// it sleeps, s of simulated time: longer than a swing's turning point or a bounce's top (where a moving
  /// cloth stops for a frame or two).
  static constexpr double kSleepAfter_s = 0.5;
  /// A sleeping cloth is still computed once per this period, s: a cloth that only seemed at rest (a hem
  /// beginning to slide off a table's edge) is seen to move further in that frame than its rest did
  /// (GuardMemory::calm_largest_step_m) and wakes.
  static constexpr double kSleepCheckPeriod_s = 1.0;
  SolverOptions solver;         ///< implicit_euler's linear solve: tolerance and iteration cap per step
  /// Threads for the force kernels and the solver on grids of 4096 particles or more. 1 by default: on
  /// the 2-vCPU machines this project is measured on, a second thread made the vectorised kernels
  /// slower, not faster (doc/BENCHMARKS.md); results are the same bits for any value.
  int threads = 1;
  double frame_rate_hz = 50.0;  ///< frames per simulated second; one frame = 1 / frame_rate_hz s

  /// Texture image (PNG/JPEG path) sampled per vertex; empty: the built-in checker pattern.
  std::string texture;

  /// Simulated depth cameras looking at the scene (the node renders them; the physics ignores them).
  std::vector<CameraOptions> cameras;

  double frameDuration_s() const { return 1.0 / frame_rate_hz; }
  bool autoSubsteps() const { return substeps == kAutoSubsteps; }
  /// The step of a fixed substep count, s (with `auto` the guard decides it frame by frame).
  double substep_s() const { return frameDuration_s() / substeps; }
};

/// The paper's cloth (1 m x 1 m on 20 x 20 particles): air damping and the paper's wind coefficient are
/// per particle and per triangle of this size, and a material scene scales them by its own particles'
/// and triangles' area, so they act per area, the same at every resolution, and unchanged on this grid.
inline constexpr double kPaperParticleArea_m2 = 1.0 / 400.0;
inline constexpr double kPaperTriangleArea_m2 = 1.0 / (2.0 * 19.0 * 19.0);

/// The options with a material's derived values in force: mass and the three spring kinds from
/// materialConstants (unchanged without a material, or with rows or cols outside OptionLimits, which
/// validation refuses). Idempotent.
SceneOptions resolveMaterial(const SceneOptions& options);
/// Air damping per particle, N s/m: air_damping as given, or in a material scene scaled by the particles'
/// mean area over kPaperParticleArea_m2.
double airDampingPerParticle_N_s_per_m(const SceneOptions& options);
/// The paper wind's coefficient per triangle, N s/m: as given, or in a material scene scaled by the
/// triangles' area over kPaperTriangleArea_m2.
double paperWindCoefficientPerTriangle_N_s_per_m(const SceneOptions& options);

/// Which particles the outline keeps (1) and removes (0), one per particle; empty without an outline. It
/// keeps the corners of the grid's triangles whose three corners are inside it (a particle on the outline
/// counts as inside, to 1e-9 of the spacing): a particle inside but in none of those triangles is removed
/// too, since it would have no area (and a material no mass).
std::vector<std::uint8_t> outlineMask(const SceneOptions& options);

/// The curvature bending term of these options: built when bend_model is curvature and there is a
/// material, cleared otherwise.
void buildCurvatureBending(const SceneOptions& options, CurvatureBending* curvature,
                           const std::vector<std::uint8_t>& active = {});

/// A number as it is written where it must read back exactly (a refused value, a saved scene): the fewest
/// significant digits, from fewest_digits up to 17, that read back as the same double, sign of zero
/// included, in printf's %g form ("nan", "inf" as printf spells them).
std::string exactNumberText(double value, int fewest_digits);

/// Every problem with the options, each naming the field, its value and the allowed range, e.g.
/// "rows = 1: must be in [2, 512]". Empty when the options are valid.
std::vector<std::string> validateSceneOptions(const SceneOptions& options);

/// The problems of one frame collider on its own (a URDF link's), each naming its field as a scene's
/// frame_colliders entry does without the entry's index ("radius = -1: must be in (0, 100]").
std::vector<std::string> validateFrameCollider(const FrameCollider& collider);

/// Whether two scene options build the same cloth grid (rows, columns, sides, pose, pins and their
/// motion, mass, whether a material sets it, outline): a retune or a restored snapshot must keep the grid.
bool sameClothGrid(const SceneOptions& a, const SceneOptions& b);
/// The first of those that differs, as the scene keys that set it ("rows, cols", "pins", ...); empty if none.
std::string clothGridDifference(const SceneOptions& a, const SceneOptions& b);

/// Resolves the pin selectors to sorted, unique particle indices; an unknown selector, or rows or cols
/// outside [OptionLimits::kMinGridSide, kMaxGridSide], is reported in *error (and nothing is returned).
std::vector<int> resolvePins(const std::vector<std::string>& selectors, int rows, int cols, std::string* error);

}  // namespace cloth_sim::core
