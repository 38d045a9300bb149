// Simulation's snapshots (state files): what a snapshot holds, and the checks a snapshot from outside must
// pass before it replaces the running state.
#include "cloth_sim/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

namespace cloth_sim::core {

namespace {

/// Pin hooks and travels are differences of points that the guard and the options bound: a particle let go
/// within kDivergenceBound_m less a pin motion within kMaxCoordinate_m; a rest position (origin within
/// kMaxCoordinate_m plus the cloth's sides) less a pin position. No valid run leaves this box (m).
constexpr double kMaxHookComponent_m =
    Simulation::kDivergenceBound_m + OptionLimits::kMaxCoordinate_m + 2.0 * OptionLimits::kMaxClothSide_m;

/// A particle this fast crosses the guard's whole box within the shortest frame the options allow: no
/// state the guard accepts carries on from there, so a snapshot with such a speed is refused (m/s).
constexpr double kMaxSpeed_m_per_s = 2.0 * Simulation::kDivergenceBound_m * OptionLimits::kMaxFrameRateHz;

/// Empty when every column of `values` (3 x expected_columns) is finite with each component within
/// +-bound (the guard's box); else what is wrong, naming `what`.
std::string checkColumns(const std::string& what, const Eigen::Matrix3Xd& values, Eigen::Index expected_columns,
                         double bound) {
  if (values.cols() != expected_columns) {
    return what + " has " + std::to_string(values.cols()) + " entries, expected " + std::to_string(expected_columns);
  }
  for (Eigen::Index i = 0; i < values.cols(); ++i) {
    if (!values.col(i).allFinite() || values.col(i).cwiseAbs().maxCoeff() > bound) {
      return what + "[" + std::to_string(i) + "] = " + vectorText(values.col(i)) +
             ": each component must be finite and within +-" + std::to_string(bound);
    }
  }
  return "";
}

/// Empty when the state fits a grid of `particles` particles; else the first problem.
std::string checkState(const ClothState& state, int particles) {
  if (std::string problem = checkColumns("state positions", state.positions_m, particles,
                                         Simulation::kDivergenceBound_m);
      !problem.empty()) {
    return problem;
  }
  if (std::string problem = checkColumns("state velocities", state.velocities_m_per_s, particles, kMaxSpeed_m_per_s);
      !problem.empty()) {
    return problem;
  }
  // Bounds the simulation itself keeps (advanceFrame stops there), so time still advances by a frame
  // and the counter cannot wrap: a file with time 1e300 s and frame 2^64 - 1 froze both.
  if (!std::isfinite(state.time_s) || state.time_s < 0.0 || state.time_s > OptionLimits::kMaxSimTime_s) {
    std::ostringstream out;
    out << "state time " << state.time_s << " s: must be in [0, " << OptionLimits::kMaxSimTime_s << "]";
    return out.str();
  }
  if (state.frame > OptionLimits::kMaxFrame) {
    return "state frame " + std::to_string(state.frame) + ": must be at most " + std::to_string(OptionLimits::kMaxFrame);
  }
  return "";
}

/// Empty when the inputs fit options (whose pins resolve to `pins`) on a grid of `particles`.
std::string checkInputs(const ClothInputs& inputs, const std::vector<int>& pins, int particles) {
  const std::string wind = windVelocityProblem(inputs.wind_m_per_s);
  if (!wind.empty()) return "wind " + vectorText(inputs.wind_m_per_s) + " m/s: " + wind;
  if (inputs.pins != pins) {
    return "inputs pin " + std::to_string(inputs.pins.size()) + " particles that differ from the " +
           std::to_string(pins.size()) + " the options' pins select";
  }
  const auto pin_count = static_cast<Eigen::Index>(pins.size());
  if (std::string problem = checkColumns("pin hooks", inputs.pin_anchors_m, pin_count, kMaxHookComponent_m);
      !problem.empty()) {
    return problem;
  }
  if (std::string problem = checkColumns("pin travel", inputs.pin_travel_m, pin_count, kMaxHookComponent_m);
      !problem.empty()) {
    return problem;
  }
  if (inputs.grasps.size() > Simulation::kMaxGrasps) {
    return std::to_string(inputs.grasps.size()) + " grasps: at most " + std::to_string(Simulation::kMaxGrasps);
  }
  for (std::size_t g = 0; g < inputs.grasps.size(); ++g) {
    const Grasp& grasp = inputs.grasps[g];
    const std::string name = "grasp " + std::to_string(grasp.id);
    for (std::size_t other = 0; other < g; ++other) {
      if (inputs.grasps[other].id == grasp.id) return name + " appears twice: ids must be unique";
    }
    if (grasp.particle < 0 || grasp.particle >= particles) {
      return name + " holds particle " + std::to_string(grasp.particle) + ": must be in [0, " +
             std::to_string(particles - 1) + "]";
    }
    const std::string values = Simulation::graspValuesProblem(grasp.target_m, grasp.stiffness_N_per_m, grasp.extra_force_N);
    if (!values.empty()) return name + " " + values;
    if (!(grasp.damping_N_s_per_m >= 0.0 && grasp.damping_N_s_per_m <= OptionLimits::kMaxDampingN_s_per_m)) {
      return name + " damping " + std::to_string(grasp.damping_N_s_per_m) + " N s/m: must be in [0, " +
             std::to_string(OptionLimits::kMaxDampingN_s_per_m) + "]";
    }
  }
  return "";
}

}  // namespace

SimulationSnapshot Simulation::snapshot() const {
  return SimulationSnapshot{options_, state_, inputs_, memory_, last_substeps_};
}

bool Simulation::restore(const SimulationSnapshot& snapshot, std::string* error) {
  // A state file holds a material, not the constants it gives: they are derived again here.
  const SceneOptions options = resolveMaterial(snapshot.options);
  const std::string difference = clothGridDifference(options, options_);
  if (!difference.empty()) {
    *error = "the snapshot's grid differs from this scene's (" + std::to_string(options_.rows) + "x" +
             std::to_string(options_.cols) + ") in " + difference;
    return false;
  }
  const std::vector<std::string> problems = validateSceneOptions(options);
  if (!problems.empty()) {
    *error = "snapshot options: " + problems.front();
    return false;
  }
  std::string problem = checkState(snapshot.state, grid_.particleCount());
  if (problem.empty()) problem = checkInputs(snapshot.inputs, inputs_.pins, grid_.particleCount());
  if (problem.empty() && snapshot.inputs.frame_colliders.size() != options.colliders.frames.size()) {
    problem = "inputs pose " + std::to_string(snapshot.inputs.frame_colliders.size()) + " frame colliders, the options have " +
              std::to_string(options.colliders.frames.size());
  }
  for (std::size_t c = 0; problem.empty() && c < snapshot.inputs.frame_colliders.size(); ++c) {
    const PoseTrack& track = snapshot.inputs.frame_colliders[c].track;
    for (const Pose* pose : {&track.start, &track.end}) {
      if (!isFinitePose(*pose, OptionLimits::kMaxCoordinate_m) || !(track.duration_s > 0.0) ||
          !std::isfinite(track.duration_s) || !std::isfinite(track.start_time_s)) {
        problem = "frame collider " + std::to_string(c) + " track: poses must be finite with unit quaternions, the duration > 0";
        break;
      }
    }
  }
  if (problem.empty()) {
    problem = checkGrippers(snapshot.inputs.grippers, inputs_.pins, grid_.particleCount(), kMaxGrippers, kMaxGraspReach_m);
  }
  const GuardMemory& guard = snapshot.guard;
  if (problem.empty() && (guard.auto_scale < 1 || guard.auto_scale > GuardMemory::kMaxScale ||
                          (guard.auto_scale & (guard.auto_scale - 1)) != 0 || guard.consecutive_rollbacks < 0 ||
                          guard.consecutive_rollbacks >= GuardMemory::kRollbacksBeforeRecovery ||
                          !(guard.frame_motion_m_per_s >= 0.0) || guard.calm_frames < 0 ||
                          guard.calm_frames > sleepAfterFrames(options))) {
    problem = "guard memory: auto scale " + std::to_string(guard.auto_scale) + " (a power of two up to " +
              std::to_string(GuardMemory::kMaxScale) + "), rollbacks in a row " +
              std::to_string(guard.consecutive_rollbacks) + " (below " +
              std::to_string(GuardMemory::kRollbacksBeforeRecovery) + "), last frame's motion " +
              std::to_string(guard.frame_motion_m_per_s) + " m/s (at least 0), calm frames " +
              std::to_string(guard.calm_frames) + " (0 to " + std::to_string(sleepAfterFrames(options)) + ")";
  }
  if (problem.empty()) {
    // Calm frames are measured from their anchor: one position per particle while there are any, none
    // else. A frame's step within the calm frames is at most twice the allowance (both ends within it).
    const bool calm = guard.calm_frames > 0;
    const Eigen::Index particles = static_cast<Eigen::Index>(options.rows) * options.cols;
    problem = checkColumns("guard memory: the calm frames' anchor (one position per particle while there are calm frames, else none)",
                           guard.calm_anchor_m, calm ? particles : 0, Simulation::kDivergenceBound_m);
    const double most_step_m = calm ? 2.0 * sleepAllowance_m(options) : 0.0;
    if (problem.empty() && !(guard.calm_largest_step_m >= 0.0 && guard.calm_largest_step_m <= most_step_m)) {
      problem = "guard memory: the calm frames' largest step " + exactNumberText(guard.calm_largest_step_m, 6) +
                " m: must be in [0, " + exactNumberText(most_step_m, 6) + "] (twice sleep_speed x " +
                exactNumberText(SceneOptions::kSleepAfter_s, 6) + " s while there are calm frames, else 0)";
    }
  }
  if (problem.empty()) problem = startsInsideCollider(options);  // a recovery's reset would start it there
  if (problem.empty() && (snapshot.last_frame_substeps < 0 || snapshot.last_frame_substeps > OptionLimits::kMaxSubsteps)) {
    problem = "last frame's substeps " + std::to_string(snapshot.last_frame_substeps) + " (0: not known, up to " +
              std::to_string(OptionLimits::kMaxSubsteps) + ")";
  }
  if (!problem.empty()) {
    *error = "snapshot " + problem;
    return false;
  }
  remakeIntegratorIfChanged(options);
  options_ = options;
  inputs_ = snapshot.inputs;
  state_ = snapshot.state;
  memory_ = snapshot.guard;
  gripper_wrenches_.clear();
  bound_stale_ = true;
  energy_cache_valid_ = false;
  // Which pins hang on hooks follows from the grasps just restored (as grab and release keep it).
  force_model_.refreshConstraints();
  last_substeps_ = snapshot.last_frame_substeps > 0 ? snapshot.last_frame_substeps : nextFrameSubsteps();
  return true;
}

}  // namespace cloth_sim::core
