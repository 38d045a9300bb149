// The stability guard, in two halves.
//
// Before a frame (predictive): bounds the highest frequency of the linearised cloth from its stiffness,
// damping, grasp springs and particle masses (Gershgorin's theorem on M^-1 K and M^-1 D, no solve), and
// turns that into the largest step each integrator's stability region allows. `substeps: auto` takes
// its substeps from that; a fixed count is reported with its margin (step / largest stable step).
//
// After a frame (detective): decides whether a computed frame is physically plausible -- finite, inside
// the 1,000 m box, no energy gained beyond what the inputs can do, no strain jump no force in the scene
// can cause -- and, if not, with how many substeps to recompute it before rolling it back.
#pragma once

#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/kinematics.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/state.h"

#include <Eigen/Core>

#include <cstdint>
#include <limits>
#include <string>

namespace cloth_sim::core {

/// Upper bounds on the rates of the linearised cloth M x'' = -K x - D x' around any state (world frame).
struct StiffnessBound {
  /// sqrt of a bound on the largest eigenvalue of M^-1 K (springs at full stretch, grasps), rad/s.
  double omega_max_rad_per_s = 0.0;
  /// Bound on the largest eigenvalue of M^-1 D from damping that grows with the spring's mode (spring
  /// and grasp damping), 1/s.
  double damping_max_per_s = 0.0;
  /// Damping every mode feels alike (air damping, the wind's drag), 1/s.
  double uniform_damping_per_s = 0.0;
  /// Lower bounds, for the methods that need damping to be stable (forward Euler, midpoint): the smallest
  /// damping-to-stiffness ratio c / k of the enabled spring kinds, s (0 if one has no damping: the
  /// fastest mode may be made of those springs alone), and air damping over the heaviest particle, 1/s.
  double damping_per_stiffness_min_s = 0.0;
  double uniform_damping_min_per_s = 0.0;
};

/// Gershgorin bounds for the scene as it is now (options, grid, per-particle masses in kg, grasps in
/// inputs). Each spring of stiffness k adds at most k to its two particles' diagonal blocks and k to the
/// off-diagonal sum (the transverse term k (1 - L/l) of a stretched spring is below k), so
/// lambda_max(M^-1 K) <= max_i 2 sum_{springs at i} k / m_i. O(springs); no solve.
StiffnessBound estimateStiffnessBound(const SceneOptions& options, const ClothGrid& grid,
                                      const Eigen::VectorXd& mass_kg, const ClothInputs& inputs);

/// The largest step (s) at which the integrator is stable for every mode under the bound: modes with
/// stiffness t omega_max^2 and damping t damping_max + uniform_damping for t in (0, 1], each required to
/// lie in the method's stability region (symplectic Euler: h^2 kappa + 2 h gamma < 4, the Jury
/// conditions of its 2x2 update; the others: |R(h s)| <= 1 with R their stability polynomial). Infinite
/// for implicit Euler; 0 when no step is stable (forward Euler and midpoint without damping).
double stableStepLimit_s(IntegratorKind kind, const StiffnessBound& bound);

/// What the guard checks a computed frame against.
struct FrameEnvelope {
  double energy_before_J = 0.0;     ///< total energy (kinetic, gravity, springs, grasps) at the frame's start
  double energy_allowance_J = 0.0;  ///< most energy the inputs (wind, moving pins and colliders) can add
  double strain_before = 0.0;       ///< largest structural strain at the frame's start
  /// Strain the scene's largest force (weight, grasps, wind) can add to a structural spring: F / (k L).
  double strain_allowance = 0.0;
  /// Self-collision's stretch ratio at the frame's start (selfCollisionStretchRatio; 0 when it is off).
  double stretch_ratio_before = 0.0;
};

/// What a frame's budgets are made of: the scene as it stands at the frame's start.
struct EnvelopeInputs {
  const SceneOptions& options;
  const ClothGrid& grid;
  const Eigen::VectorXd& mass_kg;  ///< per particle, kg; 0 outside an outline (not cloth: it has no weight)
  const ClothInputs& inputs;
  const ClothState& state;
  const StiffnessBound& bound;  ///< of the scene as it is now
  /// The bodies that move the cloth by prescription (pins' hooks, spheres, grippers, frame colliders):
  /// their peak speeds over the frame.
  const Kinematics& kinematics;
  /// Zero for particles the cloth's bodies hold (pins, gripped): contacts leave them alone.
  const Eigen::VectorXd& inverse_mass_per_kg;
  double energy_before_J = 0.0;  ///< total energy at the frame's start (Simulation::totalEnergy_J)
  double kinetic_J = 0.0;        ///< its kinetic part
  double elastic_J = 0.0;        ///< its springs' part
  double strain_before = 0.0;    ///< largest structural strain at the frame's start
};

/// The energy and strain budgets of the frame about to be computed. The energy allowance: a slack of the
/// scene's energy scale (weight over its extent, the kinetic energy of its fastest input -- wind or body
/// --, the motion, stretch and hands it already has), the work the bodies can do moving held or touched
/// particles against their springs within the frame (a particle that starts the frame inside a link,
/// placed there by its first pose, is pushed out by its depth as if the link had travelled that far), the
/// wind's work, and rounding. The strain allowance: what the scene's largest force can stretch a
/// structural spring, plus what the fastest body can carry a particle, or push one out of a link, within
/// the frame.
FrameEnvelope frameEnvelope(const EnvelopeInputs& scene);

/// What `auto` remembers between frames, so that it does not start every frame from the same too-small
/// guess. Part of a simulation's snapshot (a restored run must choose the same substeps).
struct GuardMemory {
  /// `auto` substeps are the predicted count times this (a power of two): multiplied by what a frame
  /// needed when the guard rejected its first computation (a cloth on a table's edge that needed two
  /// implicit steps once jitters at one), and halved again once the cloth no longer needs it: every
  /// kScaleTrialFrames-th frame starts from half the scale, which is kept if the guard accepts that
  /// frame's first computation (else the frame is recomputed at the old scale, as any rejected frame).
  /// Reset when the options change or the scene is reset. It only ratcheted up before: after grasp jerks
  /// a cloth at rest kept 64 substeps a frame for good (issue 18).
  int auto_scale = 1;
  int consecutive_rollbacks = 0;  ///< frames rolled back in a row (recovery starts at kRollbacksBeforeRecovery)
  /// The farthest any particle moved in the last accepted frame, over the frame's duration (m/s; infinity
  /// until a frame is accepted after a reset, retune, recovery or restoreState, or after loading a state
  /// file older than version 4): whether the cloth is calm enough for a trial at half the scale. Measured from
  /// positions, not velocities: a layer resting on another on the floor carries the upper layer's weight
  /// as a velocity the floor takes off every step, and a folded towel at rest never looked calm by it.
  double frame_motion_m_per_s = std::numeric_limits<double>::infinity();
  /// Frames in a row computed while nothing drove the cloth and no particle got further from where it
  /// was when they began (calm_anchor_m) than Simulation::sleepAllowance_m(), up to
  /// Simulation::sleepAfterFrames(): from there on the cloth sleeps.
  int calm_frames = 0;
  /// Where the particles were when the calm frames began (world frame, m; one column per particle, none
  /// while calm_frames is 0). Measured from there rather than frame to frame: a folded towel at rest can
  /// settle into a limit cycle of its contacts' friction, a particle on the floor flipping 13 um to and
  /// fro every frame for good (0.6 mm/s frame to frame, nowhere in a second), and never slept.
  Eigen::Matrix3Xd calm_anchor_m;
  /// The farthest any particle moved in one frame over the second half of the calm frames before the
  /// cloth fell asleep, m (0 while there are none): how much a frame of its rest may move. A sleeping cloth
  /// is computed once a second, and one frame cannot tell a jitter from the start of a slide: a check frame
  /// that moves further than this plus what sleep_speed moves in a frame wakes it, so a cloth that came to
  /// an exact rest wakes on the first check frame once it slides faster than sleep_speed. The first half
  /// of the calm frames is left out: a cloth arriving at rest may still move up to the allowance in its
  /// first calm frame.
  double calm_largest_step_m = 0.0;
  /// No calm frames counted (and so no anchor): the cloth must be seen at rest again before it sleeps.
  void forgetCalm() {
    calm_frames = 0;
    calm_anchor_m.resize(3, 0);
    calm_largest_step_m = 0.0;
  }
  /// What drove the last frame (Simulation's fingerprint of the inputs): a frame that starts with another
  /// one is computed, and counts as calm only from the next frame on.
  std::uint64_t drive_fingerprint = 0;
  /// Largest auto_scale: a frame that needs more than 64x the predicted substeps is not a prediction problem.
  static constexpr int kMaxScale = 1 << 6;
  /// Frames (by number) on which a scale above 1 is tried at half: 16 frames, 0.32 s at 50 Hz, so the
  /// largest scale comes back to 1 in 6 trials (about 2 s) once the cloth is calm, and a cloth that does
  /// need the scale pays one recomputed frame in 16. By frame number, so a restored run tries the same
  /// frames (with frame_motion_m_per_s, which the file keeps: save/restore stays bit-exact).
  static constexpr std::uint64_t kScaleTrialFrames = 16;
  /// Frames rolled back in a row before the simulation recovers by itself (switches to implicit Euler,
  /// and resets the scene if even that cannot compute a plausible frame).
  static constexpr int kRollbacksBeforeRecovery = 3;
};

class StabilityGuard {
 public:
  /// A state further than this from the origin (m) counts as diverged.
  static constexpr double kDivergenceBound_m = 1000.0;
  /// A diverged frame is recomputed with 2x, 4x, ... 2^kDefaultDoublings x the substeps before it is
  /// rolled back.
  static constexpr int kDefaultDoublings = 3;
  /// `auto` takes this fraction of the largest stable step: the bound is an upper bound, but the cloth is
  /// non-linear (strain stiffens the transverse terms) and contacts and pins move particles by hand.
  static constexpr double kStepSafetyFraction = 0.8;
  /// A frame may gain this fraction of the scene's energy scale (weight times extent plus the kinetic
  /// energy of its fastest input) beyond the inputs' work: integration error of a stable method stays far
  /// below it, an unstable mode passes it within a frame or two.
  static constexpr double kEnergySlackFraction = 0.5;
  /// A frame may raise the largest strain by at most this much plus kStrainGrowthFactor times the
  /// strain it started with; an unstable mode multiplies strain by orders of magnitude per frame.
  static constexpr double kStrainJump = 0.5;
  static constexpr double kStrainGrowthFactor = 2.0;

  explicit StabilityGuard(int doublings = kDefaultDoublings) : doublings_(doublings) {}

  /// Computations of one frame at most: the first, then one per doubling (one without retries).
  int attempts(bool retries) const { return retries ? doublings_ + 1 : 1; }
  /// Substeps of the given attempt (0: the first).
  int substeps(int first_substeps, int attempt) const { return first_substeps << attempt; }
  /// Empty when the frame's result may be kept; otherwise why not (for the diagnostics).
  std::string check(const ClothState& state, double energy_after_J, double strain_after,
                    const FrameEnvelope& envelope) const;

 private:
  int doublings_;
};

}  // namespace cloth_sim::core
