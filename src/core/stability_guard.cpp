#include "cloth_sim/core/stability_guard.h"

#include "cloth_sim/core/frame_colliders.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <sstream>

namespace cloth_sim::core {

namespace {

/// A particle of a regular grid belongs to at most this many triangles (the wind's damping bound).
constexpr double kTrianglesPerParticle = 6.0;
/// Speed of the cloth relative to the air assumed when bounding the aerodynamic drag's damping, on top of
/// the wind itself, m/s (a cloth that moves faster than this is caught by the energy check).
constexpr double kClothSpeedForDragBound_m_per_s = 10.0;
/// Modes sampled along t in (0, 1] when searching an explicit method's largest stable step.
constexpr int kModeSamples = 64;
/// The search for a mode's largest stable step starts from this many times 1 / rate (stableStepLimit_s).
constexpr double kUpperStepRate = 8.0;
/// Bisection on the step: relative width at which it stops.
constexpr double kBisectionRelativeWidth = 1e-6;
/// Steps below this fraction of 1/omega count as "no stable step" (forward Euler without damping).
constexpr double kSmallestStepFraction = 1e-9;
/// Energy a frame may gain from rounding alone: the kinetic energy of the whole cloth at this speed (m/s),
/// plus this fraction of the energy's magnitude (gravity's potential is measured from z = 0). Without it
/// a cloth at rest with gravity off has no allowance at all and 1e-27 J of rounding is "gained".
constexpr double kNegligibleSpeed_m_per_s = 1e-3;
constexpr double kRoundingEnergyFraction = 1e-9;

using Complex = std::complex<double>;

/// The stability polynomial of an explicit Runge-Kutta method (forward Euler, midpoint, RK4) at z = h s.
Complex stabilityPolynomial(IntegratorKind kind, Complex z) {
  switch (kind) {
    case IntegratorKind::kForwardEuler:
      return 1.0 + z;
    case IntegratorKind::kMidpoint:
      return 1.0 + z + z * z / 2.0;
    default:
      return 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;
  }
}

/// True when one damped mode x'' = -kappa x - gamma x' is stable at step h under the method.
bool modeIsStable(IntegratorKind kind, double kappa, double gamma, double step_s) {
  if (kind == IntegratorKind::kSymplecticEuler) {
    // Its update matrix [[1 - h^2 kappa, h (1 - h gamma)], [-h kappa, 1 - h gamma]] has trace
    // 2 - h^2 kappa - h gamma and determinant 1 - h gamma; Jury: |det| < 1 and |trace| < 1 + det.
    const double h_gamma = step_s * gamma;
    return h_gamma < 2.0 && step_s * step_s * kappa + 2.0 * h_gamma < 4.0;
  }
  // Roots of s^2 + gamma s + kappa = 0, the mode's eigenvalues.
  const Complex root = std::sqrt(Complex(gamma * gamma - 4.0 * kappa, 0.0));
  for (const Complex s : {(-gamma + root) / 2.0, (-gamma - root) / 2.0}) {
    if (std::abs(stabilityPolynomial(kind, step_s * s)) > 1.0) return false;
  }
  return true;
}

/// Largest h in [lower, upper] with the mode stable at h, assuming it is stable at lower and not at upper.
double bisectStep(IntegratorKind kind, double kappa, double gamma, double lower_s, double upper_s) {
  while (upper_s - lower_s > kBisectionRelativeWidth * upper_s) {
    const double middle_s = 0.5 * (lower_s + upper_s);
    (modeIsStable(kind, kappa, gamma, middle_s) ? lower_s : upper_s) = middle_s;
  }
  return lower_s;
}

}  // namespace

StiffnessBound estimateStiffnessBound(const SceneOptions& options, const ClothGrid& grid,
                                      const Eigen::VectorXd& mass_kg, const ClothInputs& inputs) {
  const int count = grid.particleCount();
  // Per particle: the sum over its springs of k (and of the damping c).
  Eigen::VectorXd stiffness_sum(count), damping_sum(count);
  stiffness_sum.setZero();
  damping_sum.setZero();
  for (int k = 0; k < kSpringKindCount; ++k) {
    const SpringOptions& spring = options.springs[k];
    if (!spring.enabled) continue;
    const SpringSet& springs = grid.springs[k];
    for (std::size_t s = 0; s < springs.first.size(); ++s) {
      for (const int particle : {springs.first[s], springs.second[s]}) {
        stiffness_sum[particle] += spring.stiffness_N_per_m;
        damping_sum[particle] += spring.damping_N_s_per_m;
      }
    }
  }
  // Gershgorin: diagonal block plus off-diagonal blocks, each at most the spring's k.
  stiffness_sum *= 2.0;
  damping_sum *= 2.0;
  for (const Grasp& grasp : inputs.grasps) {  // a grasp is a spring to a fixed target: diagonal only
    // A grasp of a particle a gripper holds does not act (ClothForceModel::graspActs): no stiffness either.
    if (inputs.gripperHolding(grasp.particle) != nullptr) continue;
    stiffness_sum[grasp.particle] += grasp.stiffness_N_per_m;
    damping_sum[grasp.particle] += grasp.damping_N_s_per_m;
  }
  CurvatureBending curvature;
  buildCurvatureBending(options, &curvature, grid.active);
  if (!curvature.empty()) {  // its rows' absolute sums are their Gershgorin radii plus the diagonal
    const Eigen::VectorXd sums = curvature.rowAbsSums();
    stiffness_sum += sums;
    damping_sum += curvature.damping_s() * sums;
  }
  double kappa_max = 0.0;
  double gamma_max = 0.0;
  double smallest_mass_kg = std::numeric_limits<double>::infinity();
  for (int i = 0; i < count; ++i) {
    kappa_max = std::max(kappa_max, stiffness_sum[i] / mass_kg[i]);
    gamma_max = std::max(gamma_max, damping_sum[i] / mass_kg[i]);
    smallest_mass_kg = std::min(smallest_mass_kg, mass_kg[i]);
  }
  double uniform_damping_N_s_per_m = airDampingPerParticle_N_s_per_m(options);
  if (options.wind_enabled && options.wind.model == WindModel::kAerodynamic) {
    const double cell_area_m2 = options.width_m / (options.cols - 1) * options.height_m / (options.rows - 1);
    const double speed_m_per_s = inputs.wind_m_per_s.norm() * (1.0 + std::abs(options.wind.gust_amplitude)) +
                                 kClothSpeedForDragBound_m_per_s;
    // d/dv of (rho C_d / 2) A |u_n| u_n is rho C_d A |u_n|; triangles are half a cell.
    uniform_damping_N_s_per_m += kTrianglesPerParticle * options.wind.air_density_kg_per_m3 *
                                 options.wind.drag_coefficient * 0.5 * cell_area_m2 * speed_m_per_s;
  }
  double ratio_min_s = std::numeric_limits<double>::infinity();
  for (const SpringOptions& spring : options.springs) {
    if (spring.enabled && spring.stiffness_N_per_m > 0.0) {
      ratio_min_s = std::min(ratio_min_s, spring.damping_N_s_per_m / spring.stiffness_N_per_m);
    }
  }
  StiffnessBound bound;
  bound.damping_per_stiffness_min_s = std::isinf(ratio_min_s) ? 0.0 : ratio_min_s;
  bound.uniform_damping_min_per_s = airDampingPerParticle_N_s_per_m(options) / mass_kg.maxCoeff();
  bound.omega_max_rad_per_s = std::sqrt(kappa_max);
  bound.damping_max_per_s = gamma_max;
  bound.uniform_damping_per_s = uniform_damping_N_s_per_m / smallest_mass_kg;
  return bound;
}

double stableStepLimit_s(IntegratorKind kind, const StiffnessBound& bound) {
  if (kind == IntegratorKind::kImplicitEuler) return std::numeric_limits<double>::infinity();
  const double kappa_max = bound.omega_max_rad_per_s * bound.omega_max_rad_per_s;
  // Nothing to resolve (no springs, no damping): every step is stable.
  if (kappa_max == 0.0 && bound.damping_max_per_s + bound.uniform_damping_per_s == 0.0) {
    return std::numeric_limits<double>::infinity();
  }
  // Forward Euler and midpoint are stable only through damping: a bound from above on it would promise
  // too large a step, so they get the damping the fastest modes are sure to have.
  const bool needs_damping = kind == IntegratorKind::kForwardEuler || kind == IntegratorKind::kMidpoint;
  // The fastest rate of the system sets the scale of the search.
  const double rate_per_s = std::max({bound.omega_max_rad_per_s, bound.damping_max_per_s + bound.uniform_damping_per_s,
                                      std::numeric_limits<double>::min()});
  double limit_s = std::numeric_limits<double>::infinity();
  for (int sample = 1; sample <= kModeSamples; ++sample) {
    const double t = static_cast<double>(sample) / kModeSamples;
    const double kappa = t * kappa_max;
    const double gamma = needs_damping ? kappa * bound.damping_per_stiffness_min_s + bound.uniform_damping_min_per_s
                                       : t * bound.damping_max_per_s + bound.uniform_damping_per_s;
    const double smallest_s = kSmallestStepFraction / rate_per_s;
    // Forward Euler's and midpoint's stability regions touch the imaginary axis only at 0: an undamped
    // oscillation grows at every step (by 1 + O(h^2) and 1 + O(h^4), below rounding for tiny h).
    const bool touches_axis_only_at_zero =
        kind == IntegratorKind::kForwardEuler || kind == IntegratorKind::kMidpoint;
    if ((touches_axis_only_at_zero && gamma <= 0.0 && kappa > 0.0) || !modeIsStable(kind, kappa, gamma, smallest_s)) {
      return 0.0;
    }
    // Past every method's limit for the binding mode: its eigenvalues are at least rate / 2 in size (a
    // critically damped mode's double root is -gamma / 2), and no method's region reaches |h s| = 4 (RK4's
    // ends by 2.96). At 4 / rate a critically damped fastest mode sat at h s = -2, inside RK4's region, and
    // was passed over as slow: the limit came out infinite, and rk4 with `auto` took 8 substeps a frame and
    // diverged at 22 to 28 per side of the hanging scene.
    const double upper_s = kUpperStepRate / rate_per_s;
    if (modeIsStable(kind, kappa, gamma, upper_s)) continue;  // a slow mode: not the binding one
    limit_s = std::min(limit_s, bisectStep(kind, kappa, gamma, smallest_s, upper_s));
  }
  return limit_s;
}

std::string StabilityGuard::check(const ClothState& state, double energy_after_J, double strain_after,
                                  const FrameEnvelope& envelope) const {
  std::ostringstream problem;
  if (!isFiniteAndBounded(state, kDivergenceBound_m)) {
    problem << "diverged (a value is not finite or left the " << kDivergenceBound_m << " m box)";
  } else if (!(energy_after_J - envelope.energy_before_J <= envelope.energy_allowance_J)) {
    problem << "gained " << energy_after_J - envelope.energy_before_J << " J in a frame, more than the "
            << envelope.energy_allowance_J << " J its inputs can add";
  } else if (!(strain_after <= kStrainJump + kStrainGrowthFactor * envelope.strain_before + envelope.strain_allowance)) {
    problem << "strain jumped from " << envelope.strain_before << " to " << strain_after
            << " in a frame, beyond what the scene's forces can stretch it";
  }
  return problem.str();
}

FrameEnvelope frameEnvelope(const EnvelopeInputs& scene) {
  const SceneOptions& options = scene.options;
  const ClothGrid& grid = scene.grid;
  const Eigen::VectorXd& mass_kg = scene.mass_kg;
  const ClothState& state = scene.state;
  const Kinematics& kinematics = scene.kinematics;
  FrameEnvelope envelope;
  envelope.energy_before_J = scene.energy_before_J;
  envelope.strain_before = scene.strain_before;
  const double total_mass_kg = mass_kg.sum();
  const double gravity_m_per_s2 = options.gravity_m_per_s2.norm();
  // The fastest thing that can push the cloth: wind (with gusts), or a body (pins' hooks, spheres,
  // grippers, frame colliders).
  const double gust = 1.0 + std::abs(options.wind.gust_amplitude);
  const double wind_speed_m_per_s = options.wind_enabled ? scene.inputs.wind_m_per_s.norm() * gust : 0.0;
  double kinematic_speed_m_per_s = 0.0;
  for (std::size_t b = 0; b < kinematics.bodies().size(); ++b) {
    kinematic_speed_m_per_s = std::max(kinematic_speed_m_per_s, kinematics.peakSpeed_m_per_s(b, state.time_s));
  }
  const double input_speed_m_per_s = std::max(wind_speed_m_per_s, kinematic_speed_m_per_s);
  const double extent_m = std::hypot(options.width_m, options.height_m) + 2.0 * options.pin_motion_amplitude_m.norm();
  // The energy scale a frame is measured against: the weight over the scene's extent, the kinetic energy of
  // its fastest input, and the motion and stretch the cloth already has.
  double grasp_energy_J = 0.0;  // what the hands hold: their springs' energy and their forces over the extent
  for (const Grasp& grasp : scene.inputs.grasps) {
    if (scene.inputs.gripperHolding(grasp.particle) != nullptr) continue;  // does not act (graspActs)
    grasp_energy_J += 0.5 * grasp.stiffness_N_per_m * (grasp.target_m - state.positions_m.col(grasp.particle)).squaredNorm() +
                      grasp.extra_force_N.norm() * extent_m;
  }
  const double scene_energy_J =
      total_mass_kg * (gravity_m_per_s2 * extent_m + 0.5 * input_speed_m_per_s * input_speed_m_per_s) +
      scene.kinetic_J + scene.elastic_J + grasp_energy_J;
  // The wind's work in a frame: at most its largest force times the fastest the cloth and air move.
  const double cloth_speed_m_per_s = state.velocities_m_per_s.colwise().norm().maxCoeff();
  const double triangles = static_cast<double>(grid.triangles.size() / 3);
  double wind_force_N = 0.0;
  if (options.wind_enabled) {
    const double relative_speed_m_per_s = wind_speed_m_per_s + cloth_speed_m_per_s;
    const double cell_area_m2 = options.width_m / (options.cols - 1) * options.height_m / (options.rows - 1);
    wind_force_N = triangles * (options.wind.model == WindModel::kPaper
                                    ? paperWindCoefficientPerTriangle_N_s_per_m(options) * wind_speed_m_per_s
                                    : 0.5 * options.wind.air_density_kg_per_m3 * options.wind.drag_coefficient *
                                          0.5 * cell_area_m2 * relative_speed_m_per_s * relative_speed_m_per_s);
  }
  // Bodies move particles by hand, against the springs: in a frame a held (or touched) particle can be
  // pushed by d = speed x frame against the load its springs already carry (at most their stiffness times
  // the strain times the longest rest length) plus the stretch of d itself, and a sphere can throw a
  // particle at twice its speed.
  const double frame_s = options.frameDuration_s();
  const double particle_stiffness_N_per_m =
      scene.bound.omega_max_rad_per_s * scene.bound.omega_max_rad_per_s * mass_kg.maxCoeff();
  const std::vector<double>& all_rest_m = grid.springsOf(SpringKind::kStructural).rest_length_m;
  const double longest_m = all_rest_m.empty() ? 0.0 : *std::max_element(all_rest_m.begin(), all_rest_m.end());
  const auto kinematicWork_J = [&](double speed_m_per_s, double particles) {
    const double travel_m = speed_m_per_s * frame_s;
    return particles * particle_stiffness_N_per_m * travel_m * (envelope.strain_before * longest_m + travel_m);
  };
  double kinematic_work_J = 0.0;
  for (std::size_t b = 0; b < kinematics.bodies().size(); ++b) {
    const int held = kinematics.heldParticles(b);
    if (held > 0) kinematic_work_J += kinematicWork_J(kinematics.peakSpeed_m_per_s(b, state.time_s), held);
  }
  for (std::size_t s = 0; s < options.colliders.spheres.size(); ++s) {
    const std::size_t body = kinematics.sphereBody(s);
    const double speed_m_per_s = kinematics.peakSpeed_m_per_s(body, state.time_s);
    const double reach_m = options.colliders.spheres[s].radius_m + speed_m_per_s * frame_s + options.contact.depth_m +
                           cloth_speed_m_per_s * frame_s;
    const Eigen::Vector3d center_m = kinematics.bodies()[body].poseAt(state.time_s).position_m;
    const double near = static_cast<double>(
        ((state.positions_m.colwise() - center_m).colwise().norm().array() <= reach_m).count());
    kinematic_work_J += kinematicWork_J(speed_m_per_s, near) +
                        near * 0.5 * mass_kg.maxCoeff() * 4.0 * speed_m_per_s * speed_m_per_s;
  }
  // A link on a tf frame pushes like a sphere the size of its bounding sphere, at the speed of its
  // farthest point (origin speed plus the turn times the bounding radius). A link's first pose places it
  // without sweeping it there (Simulation::moveFrameCollider), so it may come to rest through the cloth:
  // the contacts push each free particle inside out by its depth within the frame, the work of a link that
  // travelled that far. Without it the guard rolled that frame back, and the recovery's reset started the
  // cloth inside the link again, every third frame for good.
  double deepest_push_m = 0.0;
  for (const auto& [collider, body] : kinematics.frameColliderBodies()) {
    const FrameCollider& shape = options.colliders.frames[collider];
    const double bound_m = shape.boundingRadius_m();
    const Twist twist = kinematics.bodies()[body].twistAt(state.time_s);
    const double speed_m_per_s = twist.linear_m_per_s.norm() + twist.angular_rad_per_s.norm() * bound_m;
    const double reach_m = bound_m + speed_m_per_s * frame_s + options.contact.depth_m + cloth_speed_m_per_s * frame_s;
    const Pose pose = kinematics.bodies()[body].poseAt(state.time_s);
    const Eigen::Matrix3d to_local = pose.orientation.toRotationMatrix().transpose();
    const Eigen::VectorXd distance_m = (state.positions_m.colwise() - pose.position_m).colwise().norm().transpose();
    double near = 0.0;
    for (Eigen::Index i = 0; i < distance_m.size(); ++i) {
      if (distance_m[i] > reach_m) continue;
      near += 1.0;
      if (distance_m[i] > bound_m || scene.inverse_mass_per_kg[i] == 0.0) continue;
      Eigen::Vector3d normal;
      const double push_m =
          -shapeSignedDistance(shape, to_local * (state.positions_m.col(i) - pose.position_m), &normal) -
          options.contact.depth_m;
      if (push_m <= 0.0) continue;
      kinematic_work_J += particle_stiffness_N_per_m * push_m * (envelope.strain_before * longest_m + push_m);
      deepest_push_m = std::max(deepest_push_m, push_m);
    }
    kinematic_work_J += kinematicWork_J(speed_m_per_s, near) +
                        near * 0.5 * mass_kg.maxCoeff() * 4.0 * speed_m_per_s * speed_m_per_s;
  }
  envelope.energy_allowance_J = StabilityGuard::kEnergySlackFraction * scene_energy_J + kinematic_work_J +
                                frame_s * wind_force_N * (wind_speed_m_per_s + cloth_speed_m_per_s) +
                                0.5 * total_mass_kg * kNegligibleSpeed_m_per_s * kNegligibleSpeed_m_per_s +
                                kRoundingEnergyFraction * std::abs(envelope.energy_before_J);
  // The largest force one structural spring can be made to carry: the whole weight, every hand, the wind.
  double largest_force_N = total_mass_kg * gravity_m_per_s2 + wind_force_N;
  for (const Grasp& grasp : scene.inputs.grasps) {
    if (scene.inputs.gripperHolding(grasp.particle) != nullptr) continue;  // does not act (graspActs)
    largest_force_N += grasp.stiffness_N_per_m * (grasp.target_m - state.positions_m.col(grasp.particle)).norm() +
                       grasp.extra_force_N.norm();
  }
  const SpringOptions& structural = options.springs[static_cast<int>(SpringKind::kStructural)];
  const std::vector<double>& rest_m = grid.springsOf(SpringKind::kStructural).rest_length_m;
  const double shortest_m = rest_m.empty() ? 0.0 : *std::min_element(rest_m.begin(), rest_m.end());
  const double spring_capacity_N_per_strain = structural.enabled ? structural.stiffness_N_per_m * shortest_m : 0.0;
  // Bodies move particles by hand: in a frame they can stretch a spring by their travel.
  // A spring's two ends can be pushed out of a link in opposite directions (a link through the cloth's
  // plane pushes each particle out radially): twice the deepest push.
  const double kinematic_strain =
      shortest_m > 0.0 ? (kinematic_speed_m_per_s * frame_s + 2.0 * deepest_push_m) / shortest_m : 0.0;
  envelope.strain_allowance = spring_capacity_N_per_strain > 0.0
                                  ? largest_force_N / spring_capacity_N_per_strain + kinematic_strain
                                  : std::numeric_limits<double>::infinity();
  return envelope;
}

}  // namespace cloth_sim::core
