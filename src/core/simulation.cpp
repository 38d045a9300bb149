#include "cloth_sim/core/simulation.h"

#include "cloth_sim/core/mesh_check.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace cloth_sim::core {

namespace {

/// Squares of the built-in checker per side of the cloth.
constexpr int kCheckerSquares = 8;
/// Scales u and v in [0, 1] so that u = 1 falls in the last square rather than starting a ninth.
constexpr double kCheckerInsideScale = 0.999;
/// The checker's two colours (RGB in [0, 1]): a light sand and a dark red, apart in rviz's shading.
constexpr float kCheckerLight[3] = {0.93f, 0.86f, 0.62f};
constexpr float kCheckerDark[3] = {0.72f, 0.16f, 0.16f};

/// Empty when `given` leaves the constants its material sets as the material sets them (a retune passes
/// back what options() gave, material constants included); else which one it changed.
std::string materialConstantChanged(const SceneOptions& given, const SceneOptions& resolved) {
  if (!given.has_material) return "";
  for (int k = 0; k < kSpringKindCount; ++k) {
    const SpringOptions& a = given.springs[k];
    const SpringOptions& b = resolved.springs[k];
    if (a.enabled != b.enabled || a.stiffness_N_per_m != b.stiffness_N_per_m ||
        a.damping_N_s_per_m != b.damping_N_s_per_m) {
      return std::string(springKindName(static_cast<SpringKind>(k))) +
             " springs: set by the material in this scene (change the material instead: load a scene)";
    }
  }
  return "";
}

/// Particle masses: equal shares (the paper), or by area for a material (material.h); inside an outline
/// only, each particle outside it keeping the mean mass of those inside. It never moves (its inverse mass
/// is 0), but it is a row of the implicit system M + h c - h^2 K (its diagonal block is its mass, which
/// the block-Jacobi preconditioner inverts) and of the guard's bound (k / m and c / m per particle, and
/// the smallest mass): with 0 there those divide by zero. It is not cloth: what sums the cloth's mass
/// (energies, the guard's energy scale) uses clothMasses.
Eigen::VectorXd particleMasses(const SceneOptions& options, const ClothGrid& grid) {
  const int count = grid.particleCount();
  if (!grid.hasOutline()) {
    if (options.has_material) return areaLumpedMasses(options.rows, options.cols, options.mass_kg);
    return Eigen::VectorXd::Constant(count, options.mass_kg / count);
  }
  Eigen::VectorXd mass(count);
  const int inside = static_cast<int>(std::count(grid.active.begin(), grid.active.end(), 1));
  if (options.has_material) {
    const Eigen::VectorXd area = keptArea(grid.rows, grid.cols, options.width_m / (grid.cols - 1),
                                          options.height_m / (grid.rows - 1), grid.active);
    mass = area * (options.mass_kg / area.sum());
  } else {
    mass.setConstant(options.mass_kg / inside);
  }
  const double outside_kg = options.mass_kg / inside;
  for (int p = 0; p < count; ++p) {
    if (!grid.isActive(p)) mass[p] = outside_kg;
  }
  return mass;
}

/// The masses the cloth has: `mass_kg` with 0 on the particles outside an outline (the same vector without
/// one), so that its energies and weight count only the particles that are cloth.
Eigen::VectorXd clothMasses(const Eigen::VectorXd& mass_kg, const ClothGrid& grid) {
  Eigen::VectorXd cloth_kg = mass_kg;
  for (int p = 0; p < grid.particleCount(); ++p) {
    if (!grid.isActive(p)) cloth_kg[p] = 0.0;
  }
  return cloth_kg;
}

/// The options if they are valid; throws std::invalid_argument with the first problem otherwise.
const SceneOptions& validated(const SceneOptions& options) {
  const std::vector<std::string> problems = validateSceneOptions(options);
  if (!problems.empty()) throw std::invalid_argument("invalid scene options: " + problems.front());
  return options;
}

}  // namespace

Simulation::Simulation(const SceneOptions& options)
    : options_(resolveMaterial(validated(options))),
      grid_(buildClothGrid(options.rows, options.cols, options.width_m, options.height_m, options.origin_m,
                           options.u_axis, options.v_axis, outlineMask(options))),
      mass_kg_(particleMasses(options_, grid_)),
      cloth_mass_kg_(clothMasses(mass_kg_, grid_)),
      force_model_(grid_, options_, mass_kg_, inputs_) {
  colors_ = checkerColors(grid_.uv);
  integrator_ = makeIntegrator(options.integrator, options.solver);
  inputs_.wind_m_per_s = options.wind.velocity_m_per_s;
  reset();
  const std::string inside = startsInsideCollider(options_);
  if (!inside.empty()) throw std::invalid_argument(inside);
}

std::string Simulation::startsInsideCollider(const SceneOptions& options) const {
  // A cloth that starts inside a collider is pushed out of it within its first frame, far faster than
  // anything in the scene moves it: the guard rejects that frame, and the recovery's reset starts it inside
  // again, for good (a 20x20 hanging cloth through a 10 cm ball rolled back every frame). Within the
  // contact band it is only a contact; pinned particles are not the colliders' (contacts leave them alone:
  // a clamp may hold a pin).
  std::vector<std::uint8_t> free_particles(static_cast<std::size_t>(grid_.particleCount()));
  const Eigen::VectorXd& inverse_mass = force_model_.inverseMass_per_kg();
  for (int p = 0; p < grid_.particleCount(); ++p) {
    free_particles[static_cast<std::size_t>(p)] = grid_.isActive(p) && inverse_mass[p] != 0.0;
  }
  const std::string inside = colliderHoldingParticles(options.colliders, options.contact.depth_m + kStartInsideTolerance_m,
                                                      0.0, grid_.rest_positions_m, free_particles);
  if (inside.empty()) return "";
  return "the cloth starts inside a collider: " + inside + "; move the collider or the cloth (origin, u_axis, v_axis, pins)";
}

Simulation::~Simulation() = default;

void Simulation::reset() {
  const int count = grid_.particleCount();
  std::string unused;
  inputs_.pins = resolvePins(options_.pins, grid_.rows, grid_.cols, &unused);
  inputs_.pin_anchors_m.resize(3, static_cast<Eigen::Index>(inputs_.pins.size()));
  inputs_.pin_travel_m.setZero(3, static_cast<Eigen::Index>(inputs_.pins.size()));
  for (std::size_t p = 0; p < inputs_.pins.size(); ++p) {
    const Eigen::Vector3d start_m = grid_.rest_positions_m.col(inputs_.pins[p]);
    inputs_.pin_anchors_m.col(p) = options_.pin_positions_m.empty() ? start_m : options_.pin_positions_m[p];
    if (options_.pin_travel_time_s > 0.0) inputs_.pin_travel_m.col(p) = start_m - inputs_.pin_anchors_m.col(p);
  }
  inputs_.grasps.clear();
  inputs_.grippers.clear();  // the scene starts again as it was built: nothing holds it
  // The links stay where they were last seen (their frames will say where they go next).
  inputs_.frame_colliders.resize(options_.colliders.frames.size());
  gripper_wrenches_.clear();
  memory_ = GuardMemory();
  bound_stale_ = true;
  energy_cache_valid_ = false;
  force_model_.refreshConstraints();
  state_.positions_m = grid_.rest_positions_m;
  state_.velocities_m_per_s.setZero(3, count);
  state_.time_s = 0.0;
  state_.frame = 0;
  force_model_.enforceConstraints(0.0, state_);
  last_substeps_ = nextFrameSubsteps();
}

bool Simulation::restoreState(const ClothState& state, std::string* error) {
  SimulationSnapshot current = snapshot();
  current.state = state;
  // The last frame's motion was the old state's: the new one has not been seen moving.
  current.guard.frame_motion_m_per_s = GuardMemory().frame_motion_m_per_s;
  current.guard.forgetCalm();
  current.last_frame_substeps = 0;  // nor was it computed here
  return restore(current, error);
}

ContactStats Simulation::integrateFrame(int substeps, StepReport* steps, SelfCollisionStats* self_collision) {
  ContactStats contacts;
  const double step_s = options_.frameDuration_s() / substeps;
  const double frame_start_s = state_.time_s;
  const Eigen::VectorXd& inverse_mass = force_model_.inverseMass_per_kg();
  // Static friction's test needs the forces where each step ended: one more evaluation a substep, only
  // in scenes with planes, boxes or spheres and friction (robot links on frames keep the velocity test).
  // They are taken where the contacts will put each particle (on a surface it went into, not below it;
  // liftOntoSurfaces, which takes boxes after spheres where the contacts take them before, so a particle
  // inside two overlapping colliders may be read on the other one's surface), less the part the step's
  // solve left unsolved (Integrator::subtractSolveShortfall): both are the step's
  // numerics, not the cloth's load, and on a fine grid's stiff springs they read as several times a
  // particle's weight, so that no particle of a folded towel's lower layer passed the test and the towel
  // slid over the floor (doc/PHYSICS.md, "The fine-grid towel's slide over the floor").
  const ColliderSet& colliders = options_.colliders;
  const bool static_friction = options_.contact.friction > 0.0 &&
                               !(colliders.planes.empty() && colliders.boxes.empty() && colliders.spheres.empty());
  integrator_->beginFrame(substeps);
  for (int k = 0; k < substeps; ++k) {
    const double t0_s = state_.time_s;
    const bool self_colliding = options_.self_collision.enabled;
    if (!options_.colliders.empty() || self_colliding) substep_start_positions_m_ = state_.positions_m;
    if (!inputs_.grippers.empty()) {
      last_step_start_velocities_m_per_s_ = state_.velocities_m_per_s;
      last_step_s_ = step_s;
    }
    *steps += integrator_->step(force_model_, step_s, state_);
    // Times from the frame start, not summed step by step, so frames land exactly on k / frame_rate.
    state_.time_s = frame_start_s + (k + 1) * step_s;
    force_model_.enforceConstraints(state_.time_s, state_);
    if (!options_.colliders.empty()) {
      if (static_friction) {
        contact_positions_m_ = state_.positions_m;
        for (Eigen::Index i = 0; i < contact_positions_m_.cols(); ++i) {
          if (inverse_mass[i] > 0.0) liftOntoSurfaces(colliders, state_.time_s, contact_positions_m_.col(i));
        }
        force_model_.forces(contact_positions_m_, state_.velocities_m_per_s, state_.time_s, contact_forces_N_);
        integrator_->subtractSolveShortfall(step_s, contact_forces_N_);
      }
      contacts += resolveContacts(options_.colliders, options_.contact, t0_s, state_.time_s, inverse_mass,
                                  substep_start_positions_m_, state_.positions_m, state_.velocities_m_per_s,
                                  static_friction ? &contact_forces_N_ : nullptr);
      if (!options_.colliders.frames.empty()) {
        contacts += resolveFrameColliders(options_.colliders.frames, inputs_.frame_colliders, options_.contact, t0_s,
                                          state_.time_s, inverse_mass, substep_start_positions_m_, state_.positions_m,
                                          state_.velocities_m_per_s);
      }
    }
    // After the colliders, so that it sees where the table put a particle (and lifts what it pushes back
    // onto it).
    if (self_colliding) {
      *self_collision += self_collision_.resolve(grid_, options_.self_collision, options_.colliders, options_.contact,
                                                 state_.time_s, inverse_mass, substep_start_positions_m_, state_.positions_m,
                                                 state_.velocities_m_per_s);
    }
  }
  return contacts;
}

double Simulation::frameMotion_m_per_s() const {
  return (state_.positions_m - frame_start_.positions_m).colwise().norm().maxCoeff() / options_.frameDuration_s();
}

bool Simulation::calmStrain(double strain) { return strain <= kCalmStrainFraction * kStrainWarning; }

bool Simulation::isCalm(double motion_m_per_s, double strain) {
  return motion_m_per_s <= kCalmSpeed_m_per_s && calmStrain(strain);
}

int Simulation::frameAutoScale() const {
  // Only a calm cloth tries fewer substeps: one in motion (a flag in the wind, a cloth a hand drags) is
  // what needed them, and a trial there would only cost a recomputation. Nor one on its way to sleep
  // (counted calm, its last frame still to within sleep_speed): it wakes at one substep anyway, and the
  // trial itself may stir it (a folded towel's fold line sags up to kTrialSettle_m at one step, and the
  // guard refines it back to two). A cloth calm only by its anchor (a contact's limit cycle jittering
  // within sleepAllowance_m) still tries: a trial the guard refines is recomputed and stirs nothing, and
  // one it keeps (moving the cloth up to kTrialSettle_m) starts the calm frames again, once per halving.
  const bool on_its_way_to_sleep =
      memory_.calm_frames > 0 && memory_.frame_motion_m_per_s <= options_.sleep_speed_m_per_s;
  const bool trial = memory_.auto_scale > 1 && options_.guard_retries && !on_its_way_to_sleep &&
                     (state_.frame + 1) % GuardMemory::kScaleTrialFrames == 0 &&
                     isCalm(memory_.frame_motion_m_per_s, maxStructuralStrain());
  return trial ? memory_.auto_scale / 2 : memory_.auto_scale;
}

int Simulation::firstSubsteps(double stable_step_s, int auto_scale, std::string* warning) const {
  if (!options_.autoSubsteps()) return options_.substeps;
  if (options_.integrator == IntegratorKind::kImplicitEuler) return auto_scale;
  const double needed = std::ceil(options_.frameDuration_s() / (StabilityGuard::kStepSafetyFraction * stable_step_s));
  if (!(needed <= OptionLimits::kMaxSubsteps)) {
    if (warning != nullptr) *warning = std::string(integratorName(options_.integrator)) + " needs more than " +
               std::to_string(OptionLimits::kMaxSubsteps) + " substeps here: use implicit_euler";
    return OptionLimits::kMaxSubsteps;
  }
  return std::min(std::max(static_cast<int>(needed), 1) * auto_scale, OptionLimits::kMaxSubsteps);
}

void Simulation::refreshBound() {
  if (!bound_stale_) return;
  bound_ = estimateStiffnessBound(options_, grid_, mass_kg_, inputs_);
  bound_stale_ = false;
}

int Simulation::nextFrameSubsteps() {
  refreshBound();
  return firstSubsteps(stableStepLimit_s(options_.integrator, bound_), memory_.auto_scale, nullptr);
}

FrameEnvelope Simulation::frameEnvelope() const {
  // The last accepted frame's end is this frame's start: its energies and strain are reused unless
  // something outside advanceFrame changed the state or the options since (one pass over the springs
  // saved each way).
  const EnergyReport energies_now = energy_cache_valid_ ? cached_energies_ : energies();
  EnvelopeInputs scene{options_, grid_, cloth_mass_kg_, inputs_, state_, bound_, force_model_.kinematics(),
                       force_model_.inverseMass_per_kg()};
  scene.energy_before_J = totalEnergy_J(energies_now);
  scene.kinetic_J = energies_now.kinetic_J;
  scene.elastic_J = energies_now.elastic_J;
  scene.strain_before = energy_cache_valid_ ? cached_strain_ : maxStructuralStrain();
  FrameEnvelope envelope = core::frameEnvelope(scene);
  if (options_.self_collision.enabled) {
    envelope.stretch_ratio_before = selfCollisionStretchRatio(
        grid_, selfCollisionThickness_m(options_.self_collision, grid_), state_.positions_m);
  }
  return envelope;
}

bool Simulation::leavesGuarantee(const FrameReport& report, const FrameEnvelope& envelope) {
  return report.self_collision.stretch_ratio > SelfCollision::kGuaranteedStretchRatio &&
         envelope.stretch_ratio_before <= SelfCollision::kGuaranteedStretchRatio && report.self_collision.contacts > 0;
}

int Simulation::crossingsMade(const SelfCollisionStats& stats, bool always) const {
  if (!options_.self_collision.enabled) return 0;
  if (!always && !(stats.largest_stretch_ratio > SelfCollision::kGuaranteedStretchRatio)) return 0;
  // Every pair, not only those of the over-stretched triangles: the twisted strip's crossings were near
  // pairs beside them.
  const std::vector<std::pair<int, int>> after = crossingTrianglePairs(grid_.triangles, state_.positions_m);
  if (after.empty()) return 0;
  // Pairs that crossed before the frame (the guard kept such a frame, saying so) are not new.
  const std::vector<std::pair<int, int>> before = crossingTrianglePairs(grid_.triangles, frame_start_.positions_m);
  std::vector<std::pair<int, int>> made;
  std::set_difference(after.begin(), after.end(), before.begin(), before.end(), std::back_inserter(made));
  return static_cast<int>(made.size());
}

void Simulation::computeAt(int substeps, FrameReport* report) {
  report->substeps_used = substeps;
  report->steps = StepReport();
  report->self_collision = SelfCollisionStats();
  report->contacts = integrateFrame(substeps, &report->steps, &report->self_collision);
  report->max_strain = maxStructuralStrain();
}

bool Simulation::computeFrame(const FrameEnvelope& envelope, int first_substeps, FrameReport* report) {
  std::string problem;
  bool refined_for_guarantee = false;
  futile_doublings_ = 0;
  int crossing_refinements = 0;
  int crossing_fallback_substeps = 0;  // the last computation the guard accepted but for a crossing
  for (int attempt = 0; attempt < guard_.attempts(options_.guard_retries); ++attempt) {
    const int substeps = std::min(guard_.substeps(first_substeps, attempt), OptionLimits::kMaxSubsteps);
    if (attempt > 0 && substeps == report->substeps_used) break;  // at the cap: the same again would fail again
    computeAt(substeps, report);
    const EnergyReport energies_after = energies();
    problem = guard_.check(state_, totalEnergy_J(energies_after), report->max_strain, envelope);
    // `auto` also refines a frame that first stretches the cloth past the warning (a hem caught on a
    // table's edge): more substeps follow the impact more closely. Only at the crossing and only one
    // doubling, so a cloth a hand stretches on purpose pays one recomputation and 2x from then on.
    // The same for a frame that takes self-collision's no-crossing guarantee out of force (an edge longer
    // than it allows) where layers touch: at one implicit step a towel's fold line jams there as the upper
    // half is laid down (its springs at 20-45 % strain, held by the layers' contacts), and stays jammed at
    // rest; at two it forms a round fold (measured: doc/PHYSICS.md, "Self-collision"). Only while `auto`'s
    // scale is below kGuaranteeRefinementScale: a cloth resting near the guarantee's edge crosses it again
    // and again, and refining each time took the 128x128 fold at rest to 16 steps a frame for good.
    const bool first_of_several = attempt == 0 && guard_.attempts(options_.guard_retries) > 1;
    // At the cap there is no finer attempt: refining would throw away a result the guard accepted.
    const bool refine = problem.empty() && options_.autoSubsteps() && first_of_several &&
                        first_substeps < OptionLimits::kMaxSubsteps;
    const bool leaves_guarantee = leavesGuarantee(*report, envelope) && memory_.auto_scale < kGuaranteeRefinementScale;
    if (refine && report->max_strain > kStrainWarning && envelope.strain_before <= kStrainWarning) {
      problem = "over-stretched to " + std::to_string(report->max_strain);
    } else if (refine && leaves_guarantee) {
      problem = "self-collision stretch ratio " + std::to_string(report->self_collision.stretch_ratio) +
                " (the no-crossing guarantee holds up to " +
                std::to_string(SelfCollision::kGuaranteedStretchRatio) + ")";
      refined_for_guarantee = true;
    } else if (problem.empty()) {
      // Where the guarantee was out of force, triangles may have passed through each other (near ones on the
      // grid, which it never covers, or far ones): a finer computation follows the layers more closely (the
      // twisted strip's crossings arose at 4 substeps a frame and not at 8: doc/PHYSICS.md). At the finest
      // the guard tries, the frame is kept and says so. Once refined for a crossing, a frame is checked
      // whatever its stretch, so that a crossing the finer computation kept is not kept in silence.
      const int crossed = crossingsMade(report->self_collision, crossing_refinements > 0);
      const int next_substeps = guard_.substeps(first_substeps, attempt + 1);
      if (crossed > 0 && crossing_refinements < kMostCrossingRefinements &&
          attempt + 1 < guard_.attempts(options_.guard_retries) && next_substeps <= OptionLimits::kMaxSubsteps) {
        ++crossing_refinements;
        crossing_fallback_substeps = report->substeps_used;
        problem = std::to_string(crossed) + " triangle pairs passed through each other (self-collision stretch ratio " +
                  std::to_string(report->self_collision.largest_stretch_ratio) + ")";
      } else {
        report->self_collision.crossed = crossed;
        // A refinement that did not bring the guarantee back (a hand stretching the cloth beside it, which
        // more substeps do not change) is not worth its cost in the frames after this one.
        const bool guarantee_not_back =
            refined_for_guarantee && report->self_collision.stretch_ratio > SelfCollision::kGuaranteedStretchRatio;
        futile_doublings_ = (guarantee_not_back ? 1 : 0) + (crossed > 0 ? crossing_refinements : 0);
        cached_energies_ = energies_after;
        cached_strain_ = report->max_strain;
        energy_cache_valid_ = true;
        return true;
      }
    }
    report->rejection = problem + " with " + std::to_string(report->substeps_used) + " substeps";
    state_ = frame_start_;
  }
  if (crossing_fallback_substeps > 0) {
    // The finer computations a crossing asked for all failed the guard: the frame is the last one it
    // accepted, computed again (the same bits: nothing carries from one computation to the next), with its
    // crossing reported, rather than rolled back.
    const std::string rejection = report->rejection;
    computeAt(crossing_fallback_substeps, report);
    report->self_collision.crossed = crossingsMade(report->self_collision, true);
    report->rejection = rejection;
    futile_doublings_ = 0;
    energy_cache_valid_ = false;
    return true;
  }
  report->max_strain = maxStructuralStrain();
  return false;
}

void Simulation::rememberFrame(const FrameReport& report, int first_substeps, int auto_scale) {
  // A solve cut off at its iteration cap is not a reason by itself: conjugate gradients started at zero
  // never add energy, and a result the guard accepts is kept (the diagnostics show the cap was hit).
  if (!options_.autoSubsteps()) return;
  // Start the next frames where this one succeeded: at the scale it started from (half the remembered
  // one on a trial frame) times the doublings it needed.
  const int factor = report.substeps_used / first_substeps;  // a power of two
  if (futile_doublings_ > 0) {
    // The refinements' own doublings bought nothing: drop them, keep any the guard needed besides, and
    // lower nothing (on a trial frame the first computation was not accepted as it stood).
    memory_.auto_scale = std::max(memory_.auto_scale,
                                  std::min(auto_scale * (factor >> futile_doublings_), GuardMemory::kMaxScale));
    return;
  }
  memory_.auto_scale = std::min(auto_scale * factor, GuardMemory::kMaxScale);
}

FrameReport Simulation::advanceFrame() {
  FrameReport report;
  if (state_.time_s + options_.frameDuration_s() > OptionLimits::kMaxSimTime_s || state_.frame >= OptionLimits::kMaxFrame) {
    // 31.7 years of simulated time: beyond it a frame would no longer advance time by its duration.
    report.stable = false;
    report.reason = "the simulation reached its end (" + std::to_string(OptionLimits::kMaxSimTime_s) + " s or frame " +
                    std::to_string(OptionLimits::kMaxFrame) + "): reset it";
    return report;
  }
  refreshBound();
  report.stable_step_s = stableStepLimit_s(options_.integrator, bound_);
  holdUnmovedBodies();
  const bool driven = isDriven();
  const std::uint64_t drive = driveFingerprint();
  if (sleepsThrough(driven, drive)) {
    sleepThroughFrame(&report);
    report.sleeping = true;
    return report;
  }
  // Asleep before this frame, which then is its check frame.
  const bool was_sleeping = restsAsleep(driven, drive);
  if (memory_.calm_frames >= sleepAfterFrames(options_) && (driven || drive != memory_.drive_fingerprint)) {
    // Waking: what moves it now is not what `auto`'s scale was raised for (it came to rest before it
    // slept, and no trial came on the way: frameAutoScale). From one step a frame, the guard refines
    // where this motion needs more.
    memory_.auto_scale = 1;
  }
  std::string warning;
  int auto_scale = frameAutoScale();
  int first_substeps = firstSubsteps(report.stable_step_s, auto_scale, &warning);
  const double step_s = options_.frameDuration_s() / first_substeps;
  report.stability_margin = std::isinf(report.stable_step_s) ? 0.0 : step_s / report.stable_step_s;
  if (warning.empty() && report.stability_margin > 1.0) {
    std::ostringstream fixed;
    fixed << "step " << step_s << " s is " << report.stability_margin << "x the largest stable step of "
          << integratorName(options_.integrator) << " (" << report.stable_step_s << " s): use substeps: auto";
    warning = fixed.str();
  }
  frame_start_ = state_;
  const FrameEnvelope envelope = frameEnvelope();
  bool accepted = computeFrame(envelope, first_substeps, &report);
  double motion_m_per_s = accepted ? frameMotion_m_per_s() : 0.0;
  if (accepted && auto_scale < memory_.auto_scale && report.substeps_used == first_substeps &&
      (motion_m_per_s * options_.frameDuration_s() > kTrialSettle_m || !calmStrain(report.max_strain))) {
    // A trial the guard accepts may still stir the cloth (a hem on a table's edge jitters at one implicit
    // step where it rests at two): unless the cloth stays about as calm, the frame is computed again at
    // the remembered scale and the scale kept.
    state_ = frame_start_;
    energy_cache_valid_ = false;
    auto_scale = memory_.auto_scale;
    first_substeps = firstSubsteps(report.stable_step_s, auto_scale, nullptr);
    FrameReport again;
    again.stable_step_s = report.stable_step_s;
    again.stability_margin = report.stability_margin;
    report = again;
    accepted = computeFrame(envelope, first_substeps, &report);
    motion_m_per_s = accepted ? frameMotion_m_per_s() : 0.0;
  }
  report.recomputed = accepted && report.substeps_used != first_substeps;
  last_substeps_ = report.substeps_used;
  if (accepted) {
    rememberFrame(report, first_substeps, auto_scale);
    memory_.frame_motion_m_per_s = motion_m_per_s;
    memory_.consecutive_rollbacks = 0;
    // Calm: nothing drove the cloth, nothing changed since the frame before, and it stood still. A frame
    // with a crossing the self-collision could not prevent is never calm (the guard must keep seeing it).
    countCalmFrame(!driven && drive == memory_.drive_fingerprint && report.self_collision.forced == 0 &&
                       report.self_collision.crossed == 0,
                   motion_m_per_s * options_.frameDuration_s());
    memory_.drive_fingerprint = drive;
    report.sleeping = was_sleeping && memory_.calm_frames >= sleepAfterFrames(options_);
  } else if (++memory_.consecutive_rollbacks >= GuardMemory::kRollbacksBeforeRecovery) {
    accepted = recover(envelope, &report);
  }
  std::ostringstream reason;
  if (!accepted) {
    memory_.forgetCalm();
    report.stable = false;
    reason << "frame " << state_.frame + 1 << " (" << integratorName(options_.integrator) << ") " << report.rejection
           << ": rolled back to the previous frame";
    report.reason = reason.str();
    return report;
  }
  if (!report.scene_reset) ++state_.frame;  // a reset scene starts again at frame 0, time 0
  if (!inputs_.grippers.empty()) measureGripperWrenches();
  if (!report.recovery.empty()) {
    reason << report.recovery;
  } else if (report.recomputed) {
    reason << "frame " << state_.frame << " was recomputed with " << report.substeps_used << " substeps ("
           << report.rejection << " before)";
    if (!options_.autoSubsteps()) reason << ": raise substeps or use substeps: auto";
  } else if (!warning.empty()) {
    reason << warning;
  } else if (report.max_strain > kStrainWarning && report.self_collision.forced == 0) {
    reason << "over-stretched: structural strain " << report.max_strain << " > " << kStrainWarning;
  }
  if (report.self_collision.forced > 0) {
    // Not a crossing the simulation made, but not one to pass over in silence either, whatever else the
    // frame reports (a hand dragging the cloth through itself also stretches it: the guard refines it).
    if (reason.tellp() > 0) reason << "; ";
    reason << "a pinned or gripped particle pulled the cloth through itself (" << report.self_collision.forced
           << " particle pairs the self-collision could not keep apart)";
  }
  if (report.self_collision.crossed > 0) {
    if (reason.tellp() > 0) reason << "; ";
    reason << "the cloth passed through itself: " << report.self_collision.crossed
           << " triangle pairs crossed with the self-collision stretch ratio at "
           << report.self_collision.largest_stretch_ratio << " (the no-crossing guarantee holds up to "
           << SelfCollision::kGuaranteedStretchRatio << "), at the most substeps the guard tries";
  }
  report.reason = reason.str();
  return report;
}

bool Simulation::recover(const FrameEnvelope& envelope, FrameReport* report) {
  const std::string failing = integratorName(options_.integrator);
  std::ostringstream what;
  what << memory_.consecutive_rollbacks << " frames in a row rolled back (" << report->rejection << "): ";
  if (options_.integrator != IntegratorKind::kImplicitEuler || !options_.autoSubsteps()) {
    // Implicit Euler with auto substeps cannot diverge at any stiffness the options accept (its solve can
    // still stop unconverged at the extremes: then the reset below); switch to it for good (the node shows
    // the change) rather than pay for failing attempts every frame.
    options_.integrator = IntegratorKind::kImplicitEuler;
    options_.substeps = SceneOptions::kAutoSubsteps;
    integrator_ = makeIntegrator(options_.integrator, options_.solver);
    memory_ = GuardMemory();
    if (computeFrame(envelope, firstSubsteps(std::numeric_limits<double>::infinity(), memory_.auto_scale, nullptr), report)) {
      what << "switched from " << failing << " to implicit_euler with substeps auto";
      report->recovery = what.str();
      return true;
    }
  }
  // Not even that: the state itself is beyond saving (or an input is). Start the scene again, keeping the
  // tuning and the wind, rather than stay frozen.
  for (const Grasp& grasp : inputs_.grasps) report->released_grasp_ids.push_back(grasp.id);
  const std::string released = idList(inputs_.grasps);
  reset();
  report->scene_reset = true;
  what << "the scene was reset to its initial state";
  if (!released.empty()) what << "; released grasp ids " << released << ": their clients must grasp again";
  report->recovery = what.str();
  report->max_strain = maxStructuralStrain();
  return true;
}

void Simulation::remakeIntegratorIfChanged(const SceneOptions& options) {
  if (options.integrator != options_.integrator || options.solver.tolerance != options_.solver.tolerance ||
      options.solver.max_iterations != options_.solver.max_iterations ||
      options.solver.preconditioner != options_.solver.preconditioner) {
    integrator_ = makeIntegrator(options.integrator, options.solver);
  }
}

bool Simulation::retune(const SceneOptions& given, std::string* error) {
  const SceneOptions options = resolveMaterial(given);
  const std::string changed = materialConstantChanged(given, options);
  if (!changed.empty()) {
    *error = changed;
    return false;
  }
  if (const std::string difference = clothGridDifference(options, options_); !difference.empty()) {
    *error = difference + " cannot change while running: load a scene instead";
    return false;
  }
  const std::vector<std::string> problems = validateSceneOptions(options);
  if (!problems.empty()) {
    *error = problems.front();
    return false;
  }
  if (const std::string inside = startsInsideCollider(options); !inside.empty()) {
    *error = inside;  // a recovery's reset would start it there
    return false;
  }
  remakeIntegratorIfChanged(options);
  options_ = options;
  inputs_.frame_colliders.resize(options_.colliders.frames.size());  // new links are unseen until posed
  force_model_.refreshConstraints();  // the pins' swing and the spheres may have changed
  bound_stale_ = true;
  energy_cache_valid_ = false;
  memory_ = GuardMemory();
  return true;
}

void Simulation::setWindVelocity(const Eigen::Vector3d& wind_m_per_s) {
  inputs_.wind_m_per_s = wind_m_per_s;
  options_.wind_enabled = true;
  bound_stale_ = true;
  energy_cache_valid_ = false;
}

bool Simulation::setVertexColors(const Eigen::Matrix3Xf& colors) {
  if (colors.cols() != grid_.particleCount()) return false;
  colors_ = colors;
  return true;
}

EnergyReport Simulation::energies() const {
  EnergyReport report;
  // Of the cloth only: a particle outside an outline has a mass for the solver's sake, not weight.
  report.kinetic_J =
      0.5 * (state_.velocities_m_per_s.colwise().squaredNorm().transpose().cwiseProduct(cloth_mass_kg_)).sum();
  report.potential_J = -(options_.gravity_m_per_s2.transpose() * state_.positions_m * cloth_mass_kg_)(0);
  for (int k = 0; k < kSpringKindCount; ++k) {
    if (!options_.springs[k].enabled) continue;
    report.elastic_J += springPotentialEnergy(grid_.springs[k], options_.springs[k], state_.positions_m);
  }
  report.elastic_J += force_model_.bendingEnergy_J(state_.positions_m);
  report.potential_J += report.elastic_J;
  return report;
}

double Simulation::totalEnergy_J(const EnergyReport& energies) const {
  double total_J = energies.kinetic_J + energies.potential_J;
  for (const Grasp& grasp : inputs_.grasps) {
    if (!force_model_.graspActs(grasp)) continue;  // on a particle a gripper holds: no force, no energy
    // A hand is a spring to its target plus a constant force: both conservative while the hand stays.
    const Eigen::Vector3d position_m = state_.positions_m.col(grasp.particle);
    total_J += 0.5 * grasp.stiffness_N_per_m * (grasp.target_m - position_m).squaredNorm() -
               grasp.extra_force_N.dot(position_m);
  }
  return total_J;
}

double Simulation::maxStructuralStrain() const {
  return maxSpringStrain(grid_.springsOf(SpringKind::kStructural), state_.positions_m);
}

Eigen::Matrix3Xf checkerColors(const Eigen::Matrix2Xd& uv) {
  const Eigen::Vector3f light(kCheckerLight[0], kCheckerLight[1], kCheckerLight[2]);
  const Eigen::Vector3f dark(kCheckerDark[0], kCheckerDark[1], kCheckerDark[2]);
  Eigen::Matrix3Xf colors(3, uv.cols());
  for (Eigen::Index i = 0; i < uv.cols(); ++i) {
    const int square_u = static_cast<int>(uv(0, i) * kCheckerInsideScale * kCheckerSquares);
    const int square_v = static_cast<int>(uv(1, i) * kCheckerInsideScale * kCheckerSquares);
    colors.col(i) = ((square_u + square_v) % 2 == 0) ? light : dark;
  }
  return colors;
}

}  // namespace cloth_sim::core
