// A cloth scene in motion: options + grid + state + integrator, advanced one frame at a time.
// Deterministic: no clocks, no threads, no randomness; the same options and inputs give the same bits.
#pragma once

#include "cloth_sim/core/contact.h"
#include "cloth_sim/core/force_model.h"
#include "cloth_sim/core/forces.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/grippers.h"
#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/snapshot.h"
#include "cloth_sim/core/stability_guard.h"
#include "cloth_sim/core/state.h"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// A request to hold a particle (paper §5). particle = -1: the particle nearest to the target when the
/// grab starts. stiffness 0: the scene's grasp_stiffness_N_per_m.
struct GraspRequest {
  std::uint32_t id = 0;
  int particle = -1;
  Eigen::Vector3d target_m = Eigen::Vector3d::Zero();  ///< world frame
  double stiffness_N_per_m = 0.0;
  Eigen::Vector3d extra_force_N = Eigen::Vector3d::Zero();  ///< world frame (the simulation's), N
};

/// A request to hold particles rigidly in a frame (issue 14's ~attach). Empty particles: every particle
/// within radius_m of the frame's origin. max_force_N 0: never slips.
struct GripperRequest {
  std::uint32_t id = 0;
  std::string frame;  ///< the tf frame's name, kept for messages
  Pose pose;          ///< the frame's pose now, world frame
  double radius_m = 0.0;
  std::vector<int> particles;
  double max_force_N = 0.0;
};

struct EnergyReport {
  double kinetic_J = 0.0;
  double potential_J = 0.0;  ///< gravity (relative to z = 0 along -gravity) plus elastic spring energy
  double elastic_J = 0.0;    ///< the springs' part of potential_J
};

/// The outcome of one frame.
struct FrameReport {
  bool stable = true;     ///< false: the guard rejected every computation of the frame and rolled it back
                          ///< (the state is the previous one)
  std::string reason;     ///< why it is not OK: empty, a warning (recomputed, margin, over-stretched, recovered)
                          ///< or the rollback
  int substeps_used = 0;  ///< substeps of the accepted (or last tried) computation of the frame
  bool recomputed = false;  ///< the guard rejected the first computation and recomputed with more substeps
  std::string rejection;    ///< the guard's last objection (empty if the first computation was accepted)
  /// Non-empty when repeated rollbacks made the simulation recover by itself: what it did (switched to
  /// implicit Euler, or reset the scene). The node reports it as an ERROR.
  std::string recovery;
  bool scene_reset = false;  ///< the recovery reset the scene (state at frame 0, time 0)
  /// Ids of the grasps a scene reset let go (their clients must be told: recovery names them too).
  std::vector<std::uint32_t> released_grasp_ids;
  /// The integrator's largest stable step for this scene's bound on its frequencies, s (infinite for
  /// implicit Euler) and the first computation's step divided by it: above 1 the step is past the
  /// method's stability limit, near 1 it is close to it.
  double stable_step_s = 0.0;
  double stability_margin = 0.0;
  ContactStats contacts;  ///< summed over the frame's substeps
  /// Self-collision's work summed over the frame's substeps (all zero when it is off).
  SelfCollisionStats self_collision;
  StepReport steps;       ///< the integrator's work summed over the accepted computation's substeps
  double max_strain = 0.0;  ///< largest structural stretch (|d| - L) / L after the frame
  /// The cloth slept through the frame (SceneOptions::sleep_speed_m_per_s): nothing was computed, the
  /// state is the last frame's with time and frame number advanced; substeps_used and steps are 0, and
  /// contacts and self_collision are empty.
  bool asleep = false;
  /// The cloth sleeps after the frame: it slept through it, or the frame was one a sleeping cloth computes
  /// once a second to check on itself (Simulation::sleepCheckFrames) and found it still at rest. What a
  /// report of the cloth's state says (asleep alone is false on every check frame).
  bool sleeping = false;
};

class Simulation {
 public:
  /// A state further than this from the origin (m) counts as diverged.
  static constexpr double kDivergenceBound_m = StabilityGuard::kDivergenceBound_m;
  /// Structural stretch above this is reported as a warning (the cloth is over-stretched).
  static constexpr double kStrainWarning = 0.5;
  /// A body moving slower than this (m/s) holds still as far as sleep goes: tf interpolating between two
  /// equal transforms, or a pose sent again, may differ from the last in its last bits, which must not
  /// keep a cloth awake (1 nm/s: 1 um in a quarter of an hour).
  static constexpr double kHeldStillSpeed_m_per_s = 1e-9;
  /// Frames the cloth must stay calm before it sleeps: SceneOptions::kSleepAfter_s at the frame rate (at
  /// least 1).
  static int sleepAfterFrames(const SceneOptions& options);
  /// How far a particle may get from where it was when the calm frames began and the cloth still count as
  /// at rest, m: sleep_speed over SceneOptions::kSleepAfter_s (50 um at the defaults), so that its mean
  /// speed over the calm frames stays under sleep_speed, however it jitters within that.
  static double sleepAllowance_m(const SceneOptions& options);
  /// A sleeping cloth is computed on the frames whose number is a multiple of this
  /// (SceneOptions::kSleepCheckPeriod_s at the frame rate).
  static int sleepCheckFrames(const SceneOptions& options);

  /// A grasp target further than this from the origin (m) is refused.
  static constexpr double kMaxGraspReach_m = 1000.0;
  /// A grasp's extra force above this magnitude is refused, N.
  static constexpr double kMaxGraspForce_N = 1e4;
  /// Why a grasp's target (m), stiffness (N/m) and extra force (N) cannot be held ("target (x, y, z) m:
  /// must be ..."), or "" when they can: one rule for a new GRAB (grab) and a restored grasp (restore).
  static std::string graspValuesProblem(const Eigen::Vector3d& target_m, double stiffness_N_per_m,
                                        const Eigen::Vector3d& extra_force_N);
  /// Most grasps held at once; each costs work in every force evaluation.
  static constexpr std::size_t kMaxGrasps = 16;
  /// Most grippers held at once (the issue asks for at least 8).
  static constexpr std::size_t kMaxGrippers = 16;
  /// Fastest a gripper's origin is followed, m/s: a frame that leaps further in one frame (tf lost it and
  /// it reappears far away) is caught up with at this speed over several frames, so the cloth is carried,
  /// not torn. 5x the robot-link speed the issue asks to handle.
  static constexpr double kMaxGripperSpeed_m_per_s = 25.0;
  /// A rejected frame is recomputed with 2x, 4x, ... 2^kGuardDoublings x the substeps before it is rolled back.
  static constexpr int kGuardDoublings = StabilityGuard::kDefaultDoublings;

  /// options must have passed validateSceneOptions; throws std::invalid_argument otherwise.
  explicit Simulation(const SceneOptions& options);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const SceneOptions& options() const { return options_; }
  const ClothGrid& grid() const { return grid_; }
  const ClothState& state() const { return state_; }
  const std::vector<int>& pinnedParticles() const { return inputs_.pins; }
  /// Grasps, pin hooks and wind in force: with options() and state() a complete snapshot.
  const ClothInputs& inputs() const { return inputs_; }
  /// The right-hand side the integrator steps (forces, differential, constraints).
  ClothForceModel& forceModel() { return force_model_; }
  /// Per particle, kg. A particle outside an outline has the mean mass of those inside (it never moves;
  /// the solver and the guard divide by it), which energies() does not count.
  const Eigen::VectorXd& massPerParticle_kg() const { return mass_kg_; }

  /// Advances one frame (options().frameDuration_s()) in options().substeps substeps, or with `auto` in as
  /// many as the integrator's stability limit needs (see StabilityGuard). A frame the guard rejects
  /// (diverged, energy gained beyond the inputs' work, strain beyond the forces') is recomputed with more
  /// substeps (see kGuardDoublings, unless options().guard_retries is off); if every attempt is rejected
  /// the state is restored to the frame's start. After GuardMemory::kRollbacksBeforeRecovery such frames
  /// in a row it recovers by itself: implicit Euler with auto substeps from then on, or, if even that is
  /// rejected, the scene's initial state. The report says which happened.
  FrameReport advanceFrame();

  /// Back to the scene's initial state: grasps released, pins re-hooked. Tuning (retune, wind) is kept.
  void reset();
  /// Replaces the state, keeping options, inputs and `auto`'s scale (not the last frame's motion: the
  /// state is not calm until a frame of it has run); false with *error (state unchanged) if it would not
  /// pass restore(): wrong particle count, non-finite or out-of-bound values.
  bool restoreState(const ClothState& state, std::string* error);

  /// Live tuning: accepts new options when they keep the grid (sameClothGrid: rows, cols, size, pose,
  /// pins and their motion, mass or material, outline) and validate. The state carries on. False with
  /// *error otherwise (naming what may not change: clothGridDifference), options unchanged.
  bool retune(const SceneOptions& options, std::string* error);

  /// Sets the mean wind velocity in force (an input: world frame, m/s) and switches wind on. retune and
  /// reset leave the wind in force alone; options().wind.velocity_m_per_s is only the scene's initial wind.
  void setWindVelocity(const Eigen::Vector3d& wind_m_per_s);

  /// Starts a grasp, or moves the target of an existing one with the same id (the held particle stays).
  /// A grasped pin comes off its hook. False with *error (and nothing changed) for an out-of-range
  /// particle, non-finite/absurd values, or more than kMaxGrasps grasps.
  bool grab(const GraspRequest& request, std::string* error);
  /// The particle nearest to point_m (world frame, m) in the current state.
  int nearestParticle(const Eigen::Vector3d& point_m) const;
  /// Lets go; a pin no other grasp holds is hooked again where it was let go. False if no grasp has that id.
  bool release(std::uint32_t id);
  const std::vector<Grasp>& grasps() const { return inputs_.grasps; }

  /// Holds particles rigidly in a frame: each keeps the offset it has in request.pose now, and follows the
  /// frame as moveGripper moves it. *held gets the particles now held. False with *error (nothing changed)
  /// for an id in use, non-finite or negative values, a particle out of range, pinned or held by another
  /// gripper (named), a radius that catches nothing, or more than kMaxGrippers grippers.
  bool attachGripper(const GripperRequest& request, std::vector<int>* held, std::string* error);
  /// Lets go of a gripper's particles (they fall). False if no gripper has that id.
  bool detachGripper(std::uint32_t id);
  /// Where gripper `id`'s frame is at the end of the next frame (world frame): the held particles move
  /// there over that frame, rotation included (at most kMaxGripperSpeed_m_per_s). Without a call before a
  /// frame the gripper stays where it was. False with *error for an unknown id or a non-finite pose.
  bool moveGripper(std::uint32_t id, const Pose& end, std::string* error);
  const std::vector<Gripper>& grippers() const { return inputs_.grippers; }
  /// Where frame collider `index` (options().colliders.frames) is at the end of the next frame: `frame` is
  /// its tf frame's pose (world frame), composed here with the collider's offset. Its first pose places it
  /// (it collides with nothing before); later ones sweep it there over the frame. Without a call before a
  /// frame it stays where it was. False with *error for an index out of range or a non-finite pose.
  bool moveFrameCollider(std::size_t index, const Pose& frame, std::string* error);
  /// The frame colliders' shape poses at the current time (unseen ones: not posed), world frame.
  const std::vector<FrameColliderTrack>& frameColliders() const { return inputs_.frame_colliders; }
  /// What the cloth did to each gripper over the last frame (in inputs().grippers order), including the
  /// particles that slipped out of it (max_force); empty before the first frame with grippers.
  const std::vector<GripperWrench>& gripperWrenches() const { return gripper_wrenches_; }

  /// Sphere centres at the current time, world frame (for tf).
  std::vector<Eigen::Vector3d> sphereCenters() const;
  /// Per-particle colour (RGB in [0, 1]) from the texture sampler set with setVertexColors, or the
  /// built-in checker pattern.
  const Eigen::Matrix3Xf& vertexColors() const { return colors_; }
  /// Replaces the colours (3 x N); false if the size is wrong.
  bool setVertexColors(const Eigen::Matrix3Xf& colors);

  EnergyReport energies() const;
  /// Kinetic, gravity, spring and grasp energy (a held particle's spring to its hand and the hand's
  /// constant force; not of a grasp on a particle a gripper holds, which does not act), J, from energies()
  /// already computed: what the guard holds a frame's energy budget against.
  double totalEnergy_J(const EnergyReport& energies) const;
  double maxStructuralStrain() const;
  /// Substeps the last computed frame was computed with (with `auto`, what the guard chose; before the
  /// first frame after a start or reset(), what the first starts from; after restore(), the snapshot's).
  /// A frame slept through leaves it as it was.
  int lastFrameSubsteps() const { return last_substeps_; }
  /// What `auto` remembers between frames (part of a snapshot: a restored run chooses the same substeps).
  const GuardMemory& guardMemory() const { return memory_; }

  /// Everything needed to continue this run elsewhere: options in force, state and inputs.
  SimulationSnapshot snapshot() const;
  /// Replaces options, state and inputs with the snapshot's, all or nothing: false with *error (and
  /// nothing changed) unless the options validate and keep the grid (as retune requires), the state has
  /// this grid's particle count and is finite and within kDivergenceBound_m, and the inputs fit (the
  /// resolved pins, one hook and travel per pin, at most kMaxGrasps grasps with unique ids on existing
  /// particles, finite values within the limits grab and the wind topic enforce). Advancing after a
  /// restore gives the same bits as the run the snapshot was taken from.
  bool restore(const SimulationSnapshot& snapshot, std::string* error);

 private:
  /// The auto scale this frame starts from: the remembered one, halved on a trial frame of a calm cloth
  /// (GuardMemory::kScaleTrialFrames).
  int frameAutoScale() const;
  /// No particle moving faster than kCalmSpeed_m_per_s over a frame (motion_m_per_s: the farthest one
  /// moved, over the frame's duration) and the structural strain below kCalmStrainFraction of
  /// kStrainWarning: a cloth at rest, not one flapping, dragged or stretched over an edge.
  static bool isCalm(double motion_m_per_s, double strain);
  /// The structural strain below kCalmStrainFraction of kStrainWarning.
  static bool calmStrain(double strain);
  /// The farthest any particle moved from frame_start_ to state_, over the frame's duration (m/s).
  double frameMotion_m_per_s() const;
  static constexpr double kCalmSpeed_m_per_s = 0.05;
  /// A trial frame may move a particle this far (m) and still be kept: a layer resting on another
  /// settles a little where fewer steps put it, once. Measured at 50 Hz, the folded towel from 4 steps a
  /// frame to 2: 1.3-1.65 mm at 24 to 64 per side. Not much more: from 2 steps to 1 its fold line sagged
  /// 2.2-2.9 mm, and in the frames after, it left self-collision's guarantee (alternating trials and
  /// refinements raised its strain from 4 to 10 %). A distance, not a speed: the settling is the
  /// trial step's, whatever the frame rate (at 30 Hz the same towel settles 4.1 mm from 4 steps to 2,
  /// over the bound: it keeps its 4).
  static constexpr double kTrialSettle_m = 1.9e-3;
  static constexpr double kCalmStrainFraction = 0.5;
  /// `auto` refines a frame that takes self-collision's guarantee out of force while its scale is below
  /// this: the fold's jam needs two steps a frame and the twisted strip's near pairs four (at two, 7 of
  /// them crossed), while refining without a bound kept the 128x128 fold at rest at 16.
  static constexpr int kGuaranteeRefinementScale = 4;
  /// A frame in which triangles passed through each other is computed again with twice the substeps at
  /// most this many times: the twisted strip's crossings took one or two doublings to prevent, while at
  /// 32 rows one crossing pair stayed through eight (512 substeps a frame, 0.5 s each).
  static constexpr int kMostCrossingRefinements = 2;
  /// Substeps of a frame's first computation: the fixed count, or for `auto` the count the stable step
  /// needs times the given scale. *warning (if given) says when explicit needs more than the cap.
  int firstSubsteps(double stable_step_s, int auto_scale, std::string* warning) const;
  /// The substeps the next frame starts from (firstSubsteps at the remembered scale; a trial, a wake or
  /// the guard may still change them), with the stiffness bound brought up to date: what
  /// lastFrameSubsteps() says before a frame is computed.
  int nextFrameSubsteps();
  /// Recomputes the stiffness bound if something it depends on changed (bound_stale_).
  void refreshBound();
  /// A new integrator for `options` where its kind or its solver's settings differ from options_' (a
  /// retune or a restore; the integrator keeps no state across frames, so an unchanged one stays).
  void remakeIntegratorIfChanged(const SceneOptions& options);
  /// Why a scene with these colliders cannot start: free particles of the cloth at rest more than the
  /// contact band (plus kStartInsideTolerance_m) inside a plane, a sphere at t = 0 or a box; "" if none.
  std::string startsInsideCollider(const SceneOptions& options) const;
  /// Rounding room for a cloth lying exactly on a surface when `contact_depth` is 0, m.
  static constexpr double kStartInsideTolerance_m = 1e-9;
  /// Whether a computed frame took self-collision's no-crossing guarantee out of force (stretch ratio
  /// above SelfCollision::kGuaranteedStretchRatio, from at most it) while layers touched.
  static bool leavesGuarantee(const FrameReport& report, const FrameEnvelope& envelope);
  /// Triangle pairs passing through each other after the frame (state_) that did not at its start
  /// (frame_start_), counted where the frame took self-collision's guarantee out of force (stats' largest
  /// stretch ratio above 1), where every crossing measured arose (doc/PHYSICS.md), or `always`: elsewhere
  /// the guarantee covers all pairs but those near on the rest grid.
  int crossingsMade(const SelfCollisionStats& stats, bool always) const;
  /// The energy and strain budgets of the frame about to be computed, from the state and the inputs.
  FrameEnvelope frameEnvelope() const;
  /// Computes the frame from state_ (= frame_start_) with the guard's attempts; false (state restored)
  /// if every attempt was rejected.
  bool computeFrame(const FrameEnvelope& envelope, int first_substeps, FrameReport* report);
  /// Updates `auto`'s memory after an accepted frame.
  void rememberFrame(const FrameReport& report, int first_substeps, int auto_scale);
  /// After repeated rollbacks: implicit Euler with auto substeps, or the initial state. Always true.
  bool recover(const FrameEnvelope& envelope, FrameReport* report);
  /// Whether anything moves the cloth over the coming frame by itself: a hook, sphere, gripper or frame
  /// collider moving faster than kHeldStillSpeed_m_per_s, or a gusting wind.
  bool isDriven() const;
  /// A fingerprint of the inputs and the wind switch: a grab or drag, a release, a new wind, a gripper
  /// attached, detached or slipping, a link first seen change it. Not the bodies' poses: a body that moves
  /// drives the cloth (isDriven), and one that holds still must not wake it by its rounding.
  std::uint64_t driveFingerprint() const;
  /// Whether the cloth is asleep coming into this frame: sleep_speed is on, the last sleepAfterFrames
  /// frames were calm, and nothing drives it or changed since.
  bool restsAsleep(bool driven, std::uint64_t drive) const;
  /// Whether the cloth sleeps through the coming frame: it rests asleep and this is not a frame the
  /// sleeping cloth is checked on (sleepCheckFrames).
  bool sleepsThrough(bool driven, std::uint64_t drive) const;
  /// Advances time and frame number over a frame the cloth sleeps through; *report says so.
  void sleepThroughFrame(FrameReport* report);
  /// Counts the frame just accepted as calm or not (GuardMemory::calm_frames, calm_anchor_m and
  /// calm_largest_step_m): calm if nothing drove it (`still_inputs`) and no particle is further than
  /// sleepAllowance_m() from the calm frames' anchor (this frame's start for the first), and, for the
  /// check frame of a sleeping cloth, no particle moved further in it (`step_m`, m) than its rest did plus
  /// what sleep_speed moves in a frame.
  void countCalmFrame(bool still_inputs, double step_m);
  /// Runs one frame in the given number of substeps from the current state; adds the integrator's work
  /// to *steps.
  ContactStats integrateFrame(int substeps, StepReport* steps, SelfCollisionStats* self_collision);
  /// One computation of the frame from state_ at `substeps`: its substeps, steps, self-collision, contacts
  /// and strain go into *report (the rest of it is the caller's).
  void computeAt(int substeps, FrameReport* report);

  /// Before a frame: a gripper or frame collider that was not moved for it holds still (its track starts
  /// at this frame).
  void holdUnmovedBodies();
  /// After an accepted frame: each gripper's wrench from the constraint reactions; slipped particles let go.
  void measureGripperWrenches();

  SceneOptions options_;
  ClothGrid grid_;
  Eigen::VectorXd mass_kg_;        ///< per particle, kg; outside an outline the mean of those inside
  Eigen::VectorXd cloth_mass_kg_;  ///< mass_kg_ with 0 outside an outline: what energies and weight sum
  ClothInputs inputs_;
  ClothForceModel force_model_;  ///< reads options_, grid_, mass_kg_ and inputs_ (declared before it)
  StabilityGuard guard_;
  GuardMemory memory_;
  StiffnessBound bound_;     ///< of options_, masses and grasps; recomputed when bound_stale_
  bool bound_stale_ = true;
  int last_substeps_ = 1;  ///< see lastFrameSubsteps()
  /// Doublings of the frame just computed that bought nothing, which `auto` does not keep (scratch of
  /// advanceFrame): one where it was refined because it left self-collision's guarantee and the refined
  /// result still leaves it, and those taken for triangles passing through each other that still did.
  int futile_doublings_ = 0;
  /// Energies and strain at the end of the last accepted frame (= the next frame's start) while
  /// energy_cache_valid_; every change from outside (reset, restore, retune, grab, release, wind) clears it.
  EnergyReport cached_energies_;
  double cached_strain_ = 0.0;
  bool energy_cache_valid_ = false;
  ClothState state_;
  ClothState frame_start_;               ///< rollback point, scratch
  Eigen::Matrix3Xd substep_start_positions_m_;  ///< scratch for the contact sweep
  Eigen::Matrix3Xd contact_forces_N_;           ///< scratch: the forces static friction's test reads
  Eigen::Matrix3Xd contact_positions_m_;        ///< scratch: where it reads them (lifted onto surfaces)
  Eigen::Matrix3Xf colors_;
  std::unique_ptr<Integrator> integrator_;
  SelfCollision self_collision_;  ///< scratch only: nothing carried from one substep to the next
  /// With grippers: the velocities at the start of the last substep and its length (the held particles'
  /// acceleration over it enters their reaction), and the wrenches of the last frame.
  Eigen::Matrix3Xd last_step_start_velocities_m_per_s_;
  double last_step_s_ = 0.0;
  Eigen::Matrix3Xd gripper_forces_N_;  ///< scratch
  std::vector<GripperWrench> gripper_wrenches_;
};

/// The built-in texture: a two-colour checker of 8 x 8 squares over uv, RGB in [0, 1].
Eigen::Matrix3Xf checkerColors(const Eigen::Matrix2Xd& uv);

}  // namespace cloth_sim::core
