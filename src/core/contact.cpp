#include "cloth_sim/core/contact.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace cloth_sim::core {

namespace {

/// Below this a direction is undefined, m; a particle at a sphere's centre is pushed out along +z.
constexpr double kTinyLength_m = 1e-12;
/// Two unit face normals of an axis-aligned box are the same face when their cosine exceeds this.
constexpr double kSameFaceCosine = 0.5;

/// Where a particle stood against one collider at the start and end of a substep.
enum class Crossing { kNone, kSwept, kPenetrated };

/// True when a particle at this distance is not inside the collider (outside or in the band). A particle
/// resting on a surface sits in the band, often a rounding error below the surface: it must still count
/// as outside, or a fast collider could carry it through unnoticed.
bool notInside(double distance_m, double depth_m) { return distance_m >= -depth_m; }

/// Beyond the band at the end of the substep: a sweep hit if it started outside or in the band, else a
/// penetration.
Crossing classifyDeep(double start_distance_m, double end_distance_m, double depth_m) {
  if (notInside(end_distance_m, depth_m)) return Crossing::kNone;
  return notInside(start_distance_m, depth_m) ? Crossing::kSwept : Crossing::kPenetrated;
}

void count(Crossing crossing, ContactStats& stats) {
  if (crossing == Crossing::kSwept) ++stats.swept_hits;
  if (crossing == Crossing::kPenetrated) ++stats.penetrations;
}

/// Applies the response to velocity v (world frame) against a collider surface moving at
/// surface_velocity, if v approaches it. Returns true if it did.
bool respond(const Eigen::Vector3d& normal, const Eigen::Vector3d& surface_velocity_m_per_s,
             const ContactOptions& options, Eigen::Ref<Eigen::Vector3d> velocity_m_per_s) {
  const Eigen::Vector3d relative = velocity_m_per_s - surface_velocity_m_per_s;
  if (relative.dot(normal) >= 0.0) return false;
  velocity_m_per_s = surface_velocity_m_per_s + collisionResponse(relative, normal, options);
  return true;
}

/// What the static-friction test needs besides the response: the forces on each particle at the substep's
/// end (N, world frame; null: no test, the velocity response alone), the particles' inverse masses and
/// the substep, s.
struct StickInputs {
  const Eigen::Matrix3Xd* forces_N = nullptr;
  const Eigen::VectorXd* inverse_mass_per_kg = nullptr;
  double step_s = 0.0;
};

/// What a contact did to a particle's velocity: it approached the surface (and got the response), and
/// static friction holds it.
struct Response {
  bool approaching = false;
  bool stuck = false;
};

/// respond(), and Coulomb's static test. The response stops a particle's velocity along the surface
/// when it is within friction x the normal speed it removes; but the particle has already moved along
/// the surface over the step, and that slide is never taken back: a steady force F moves it F h^2 / m
/// a step. On a 20 degree slope at mu 0.5 a "stuck" particle crept 3.4 mm in 2 s, and the folded towel
/// of issue 15 drifted over the floor at 0.5-1.5 mm/s. A particle static friction holds is therefore
/// also put back where it started along the surface (takeBackSlide). Held means: the response stopped
/// it along the surface, AND the forces on it push along the surface by less than friction x the
/// normal force the contact applies (F_t h / m <= mu x the normal velocity change). The second test is
/// what the velocity alone cannot tell: the implicit step damps a stiff spring's pull to about
/// F / (h k) of speed, so where a hand peels a towel off the floor the velocity test holds the peel
/// front against any pull, and holding it in place stretched the springs there 44 % (measured).
Response respondAndTestStick(const Eigen::Vector3d& normal, const Eigen::Vector3d& surface_velocity_m_per_s,
                             const ContactOptions& options, const StickInputs& stick, Eigen::Index particle,
                             Eigen::Ref<Eigen::Vector3d> velocity_m_per_s) {
  // The same test as collisionResponse's (whether it keeps any sliding), decided before the response
  // from the same speeds: after it, a bounce's normal part leaves rounding in the tangential one.
  const Eigen::Vector3d relative = velocity_m_per_s - surface_velocity_m_per_s;
  const double normal_speed = relative.dot(normal);
  const double normal_change_m_per_s = (1.0 + options.restitution) * -normal_speed;
  const bool stopped = (relative - normal_speed * normal).norm() <= options.friction * normal_change_m_per_s;
  Response response;
  response.approaching = respond(normal, surface_velocity_m_per_s, options, velocity_m_per_s);
  if (!response.approaching || stick.forces_N == nullptr || !stopped) return response;  // sliding: kinetic
  const Eigen::Vector3d force_N = stick.forces_N->col(particle);
  const double along_surface_N = (force_N - force_N.dot(normal) * normal).norm();
  response.stuck = along_surface_N * (*stick.inverse_mass_per_kg)[particle] * stick.step_s <=
                   options.friction * normal_change_m_per_s;
  return response;
}

/// Puts a particle static friction holds back where it started along the surface (`start` and `end` in
/// the surface's frame; its motion along the normal stays).
void takeBackSlide(const Eigen::Vector3d& normal, const Eigen::Vector3d& start, Eigen::Ref<Eigen::Vector3d> end) {
  const Eigen::Vector3d moved = end - start;
  end -= moved - moved.dot(normal) * normal;
}

/// The first s in [0, 1] where |start + s * delta| = radius, for a segment starting outside the sphere.
double sphereEntry(const Eigen::Vector3d& start, const Eigen::Vector3d& delta, double radius_m) {
  const double a = delta.squaredNorm();
  const double b = start.dot(delta);
  const double c = start.squaredNorm() - radius_m * radius_m;
  const double discriminant = std::max(0.0, b * b - a * c);
  return std::clamp((-b - std::sqrt(discriminant)) / a, 0.0, 1.0);
}

/// Closest distance from the origin to the segment start + s * delta, s in [0, 1].
double segmentDistanceToOrigin(const Eigen::Vector3d& start, const Eigen::Vector3d& delta) {
  const double a = delta.squaredNorm();
  const double s = a > 0.0 ? std::clamp(-start.dot(delta) / a, 0.0, 1.0) : 0.0;
  return (start + s * delta).norm();
}

/// Outward normal of a box at a point: away from the nearest surface point outside, or the face of least
/// penetration inside.
Eigen::Vector3d boxNormal(const BoxCollider& box, const Eigen::Vector3d& point_m) {
  const Eigen::Vector3d clamped = point_m.cwiseMax(box.min_m).cwiseMin(box.max_m);
  const Eigen::Vector3d outside = point_m - clamped;
  if (outside.norm() > kTinyLength_m) return outside.normalized();
  double best_m = std::numeric_limits<double>::infinity();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  for (int axis = 0; axis < 3; ++axis) {
    const double to_min = point_m[axis] - box.min_m[axis];
    const double to_max = box.max_m[axis] - point_m[axis];
    if (to_min < best_m) {
      best_m = to_min;
      normal = -Eigen::Vector3d::Unit(axis);
    }
    if (to_max < best_m) {
      best_m = to_max;
      normal = Eigen::Vector3d::Unit(axis);
    }
  }
  return normal;
}

/// Slab test of the segment start -> end against a box: true with the entry parameter and the entry
/// face's outward normal if the segment enters it within [0, 1] from outside.
bool boxEntry(const BoxCollider& box, const Eigen::Vector3d& start, const Eigen::Vector3d& end, double* entry,
              Eigen::Vector3d* normal) {
  const Eigen::Vector3d delta = end - start;
  double enter = 0.0;
  double leave = 1.0;
  int enter_axis = -1;
  double enter_sign = 1.0;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(delta[axis]) < kTinyLength_m) {
      if (start[axis] < box.min_m[axis] || start[axis] > box.max_m[axis]) return false;
      continue;
    }
    double near = (box.min_m[axis] - start[axis]) / delta[axis];
    double far = (box.max_m[axis] - start[axis]) / delta[axis];
    double sign = -1.0;  // entering through the min face
    if (near > far) {
      std::swap(near, far);
      sign = 1.0;
    }
    if (near > enter) {
      enter = near;
      enter_axis = axis;
      enter_sign = sign;
    }
    leave = std::min(leave, far);
    if (enter > leave) return false;
  }
  if (enter_axis < 0) return false;  // started inside
  *entry = enter;
  *normal = enter_sign * Eigen::Vector3d::Unit(enter_axis);
  return true;
}

/// A particle that started in the band just under a face (a particle resting on the box, after rounding)
/// and ends outside or in the band again: true if its segment went through the box's deep interior (the
/// box shrunk by the band), i.e. it crossed the box within the substep instead of leaving through the face.
bool crossedFromBand(const BoxCollider& box, double depth_m, double start_distance_m, double end_distance_m,
                     const Eigen::Vector3d& start, const Eigen::Vector3d& end) {
  if (start_distance_m >= 0.0 || !notInside(start_distance_m, depth_m) || !notInside(end_distance_m, depth_m)) {
    return false;
  }
  const BoxCollider deep{box.min_m.array() + depth_m, box.max_m.array() - depth_m};
  if ((deep.max_m - deep.min_m).minCoeff() <= 0.0) return false;  // thinner than the band: no deep interior
  double entry = 0.0;
  Eigen::Vector3d normal;
  return boxEntry(deep, start, end, &entry, &normal);
}

void resolvePlane(const PlaneCollider& plane, const ContactOptions& options, const StickInputs& stick,
                  const Eigen::VectorXd& inverse_mass, const Eigen::Matrix3Xd& previous, Eigen::Matrix3Xd& positions,
                  Eigen::Matrix3Xd& velocities, ContactStats& stats) {
  const Eigen::Vector3d still = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < positions.cols(); ++i) {
    if (inverse_mass[i] == 0.0) continue;
    const double distance_m = signedDistance(plane, positions.col(i));
    if (distance_m > options.depth_m) continue;
    const Crossing crossing = classifyDeep(signedDistance(plane, previous.col(i)), distance_m, options.depth_m);
    const Response response = respondAndTestStick(plane.normal, still, options, stick, i, velocities.col(i));
    const bool approaching = response.approaching;
    if (crossing != Crossing::kNone || (approaching && distance_m < 0.0)) {
      positions.col(i) -= distance_m * plane.normal;
      if (response.stuck) takeBackSlide(plane.normal, previous.col(i), positions.col(i));
    }
    count(crossing, stats);
    if (crossing == Crossing::kNone && approaching) ++stats.band_collisions;
  }
}

void resolveSphere(const SphereCollider& sphere, const ContactOptions& options, const StickInputs& stick, double t0_s,
                   double t1_s, const Eigen::VectorXd& inverse_mass, const Eigen::Matrix3Xd& previous,
                   Eigen::Matrix3Xd& positions, Eigen::Matrix3Xd& velocities, ContactStats& stats) {
  const Eigen::Vector3d center0 = sphere.centerAt(t0_s);
  const Eigen::Vector3d center1 = sphere.centerAt(t1_s);
  const Eigen::Vector3d surface_velocity = sphere.velocityAt(t1_s);
  const double radius = sphere.radius_m;
  for (Eigen::Index i = 0; i < positions.cols(); ++i) {
    if (inverse_mass[i] == 0.0) continue;
    // In the sphere's own (translating) frame the sphere stands still and the particle moves start -> end.
    const Eigen::Vector3d start = previous.col(i) - center0;
    const Eigen::Vector3d end = positions.col(i) - center1;
    const double start_distance = start.norm() - radius;
    const double end_distance = end.norm() - radius;
    const bool tunnelled = notInside(start_distance, options.depth_m) && notInside(end_distance, options.depth_m) &&
                           segmentDistanceToOrigin(start, end - start) < radius - options.depth_m;
    Crossing crossing = classifyDeep(start_distance, end_distance, options.depth_m);
    if (tunnelled) crossing = Crossing::kSwept;
    if (crossing == Crossing::kNone && end_distance > options.depth_m) continue;

    Eigen::Vector3d normal;
    // A particle that went in but not past the centre, on the side it came from, is pushed out to the
    // nearest surface point like a penetration, keeping its motion along the surface (a cloth sliding
    // over the ball in large implicit steps). Only one that tunnelled through, or reached the far half,
    // goes back to where it first met the surface.
    const bool near_side = !tunnelled && end.dot(start) > 0.0;
    if (crossing == Crossing::kSwept && !near_side) {
      // Put it back where it first met the surface, in the sphere's frame, so it cannot come out the far side
      // (a particle that started in the band below the surface meets it at s = 0, where it stood).
      const Eigen::Vector3d entry = start + sphereEntry(start, end - start, radius) * (end - start);
      normal = entry.norm() > kTinyLength_m ? Eigen::Vector3d(entry / entry.norm()) : Eigen::Vector3d::UnitZ();
    } else {
      normal = end.norm() > kTinyLength_m ? Eigen::Vector3d(end / end.norm()) : Eigen::Vector3d::UnitZ();
    }
    const Response response = respondAndTestStick(normal, surface_velocity, options, stick, i, velocities.col(i));
    const bool approaching = response.approaching;
    if (crossing != Crossing::kNone || (approaching && end_distance < 0.0)) {
      Eigen::Vector3d surface_point = radius * normal;  // in the sphere's frame
      if (response.stuck && near_side) takeBackSlide(normal, start, surface_point);
      positions.col(i) = center1 + surface_point;
    }
    count(crossing, stats);
    if (crossing == Crossing::kNone && approaching) ++stats.band_collisions;
  }
}

void resolveBox(const BoxCollider& box, const ContactOptions& options, const StickInputs& stick,
                const Eigen::VectorXd& inverse_mass, const Eigen::Matrix3Xd& previous, Eigen::Matrix3Xd& positions,
                Eigen::Matrix3Xd& velocities, ContactStats& stats) {
  const Eigen::Vector3d still = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < positions.cols(); ++i) {
    if (inverse_mass[i] == 0.0) continue;
    const Eigen::Vector3d start = previous.col(i);
    const Eigen::Vector3d end = positions.col(i);
    const double start_distance = signedDistance(box, start);
    const double end_distance = signedDistance(box, end);
    double entry = 0.0;
    Eigen::Vector3d entry_normal;
    const bool entered = start_distance >= 0.0 && boxEntry(box, start, end, &entry, &entry_normal);
    Crossing crossing = classifyDeep(start_distance, end_distance, options.depth_m);
    if (entered && end_distance > 0.0) crossing = Crossing::kSwept;  // went in and out within the substep
    if (crossedFromBand(box, options.depth_m, start_distance, end_distance, start, end)) crossing = Crossing::kSwept;
    if (crossing == Crossing::kNone && end_distance > options.depth_m) continue;

    // A swept particle that still lies nearest the face it came through (entered through, or started on)
    // is pushed straight back out of that face, keeping its motion along it: a cloth settling on a
    // table or sliding down its side in large steps. Through and out, or nearer another face: back to
    // where it entered, or onto the face where it stood.
    const Eigen::Vector3d swept_normal = entered ? entry_normal : boxNormal(box, start);
    const bool near_swept_face =
        end_distance < 0.0 && boxNormal(box, end).dot(swept_normal) > kSameFaceCosine;
    if (crossing == Crossing::kSwept && near_swept_face) {
      const Response response = respondAndTestStick(swept_normal, still, options, stick, i, velocities.col(i));
      positions.col(i) = end - end_distance * swept_normal;
      if (response.stuck) takeBackSlide(swept_normal, start, positions.col(i));
    } else if (crossing == Crossing::kSwept && entered) {
      respond(entry_normal, still, options, velocities.col(i));
      positions.col(i) = start + entry * (end - start);
    } else if (crossing == Crossing::kSwept) {
      respond(swept_normal, still, options, velocities.col(i));
      positions.col(i) = start - start_distance * swept_normal;
    } else {
      const Eigen::Vector3d normal = boxNormal(box, end);
      const Response response = respondAndTestStick(normal, still, options, stick, i, velocities.col(i));
      const bool approaching = response.approaching;
      if (crossing != Crossing::kNone || (approaching && end_distance < 0.0)) {
        positions.col(i) = end - end_distance * normal;
        if (response.stuck) takeBackSlide(normal, start, positions.col(i));
      }
      if (crossing == Crossing::kNone && approaching) ++stats.band_collisions;
    }
    count(crossing, stats);
  }
}

}  // namespace

ScriptedMotion SphereCollider::motion() const {
  ScriptedMotion motion;
  motion.origin_m = center_m;
  motion.velocity_m_per_s = velocity_m_per_s;
  motion.swing_amplitude_m = oscillation_amplitude_m;
  motion.swing_period_s = oscillation_period_s;
  return motion;
}

ContactStats& ContactStats::operator+=(const ContactStats& other) {
  band_collisions += other.band_collisions;
  penetrations += other.penetrations;
  swept_hits += other.swept_hits;
  return *this;
}

double signedDistance(const PlaneCollider& plane, const Eigen::Vector3d& point_m) {
  return plane.normal.dot(point_m) + plane.offset_m;
}

double signedDistance(const SphereCollider& sphere, const Eigen::Vector3d& center_m, const Eigen::Vector3d& point_m) {
  return (point_m - center_m).norm() - sphere.radius_m;
}

double signedDistance(const BoxCollider& box, const Eigen::Vector3d& point_m) {
  const Eigen::Vector3d below = box.min_m - point_m;
  const Eigen::Vector3d above = point_m - box.max_m;
  const Eigen::Vector3d gap = below.cwiseMax(above);  // per axis: > 0 outside that slab
  const double largest = gap.maxCoeff();
  if (largest <= 0.0) return largest;  // inside: minus the distance to the nearest face
  return gap.cwiseMax(0.0).norm();
}

double nearestSurfaceDistance_m(const ColliderSet& colliders, double time_s, const Eigen::Vector3d& point_m,
                                Eigen::Vector3d* normal) {
  double nearest_m = std::numeric_limits<double>::infinity();
  Eigen::Vector3d nearest_normal = Eigen::Vector3d::UnitZ();
  for (const PlaneCollider& plane : colliders.planes) {
    const double distance_m = signedDistance(plane, point_m);
    if (distance_m < nearest_m) {
      nearest_m = distance_m;
      nearest_normal = plane.normal;
    }
  }
  for (const SphereCollider& sphere : colliders.spheres) {
    const Eigen::Vector3d center_m = sphere.centerAt(time_s);
    const double distance_m = signedDistance(sphere, center_m, point_m);
    if (distance_m < nearest_m) {
      nearest_m = distance_m;
      const Eigen::Vector3d out = point_m - center_m;
      nearest_normal = out.norm() > kTinyLength_m ? Eigen::Vector3d(out.normalized()) : Eigen::Vector3d::UnitZ();
    }
  }
  for (const BoxCollider& box : colliders.boxes) {
    const double distance_m = signedDistance(box, point_m);
    if (distance_m < nearest_m) {
      nearest_m = distance_m;
      nearest_normal = boxNormal(box, point_m);
    }
  }
  if (normal != nullptr) *normal = nearest_normal;
  return nearest_m;
}

bool liftOntoSurfaces(const ColliderSet& colliders, double time_s, Eigen::Ref<Eigen::Vector3d> point_m) {
  bool moved = false;
  for (const PlaneCollider& plane : colliders.planes) {
    const double distance_m = signedDistance(plane, point_m);
    if (distance_m >= 0.0) continue;
    point_m -= distance_m * plane.normal;
    moved = true;
  }
  for (const SphereCollider& sphere : colliders.spheres) {
    const Eigen::Vector3d center_m = sphere.centerAt(time_s);
    const double distance_m = signedDistance(sphere, center_m, point_m);
    if (distance_m >= 0.0) continue;
    const Eigen::Vector3d out = point_m - center_m;
    const Eigen::Vector3d normal = out.norm() > kTinyLength_m ? Eigen::Vector3d(out.normalized()) : Eigen::Vector3d::UnitZ();
    point_m = center_m + sphere.radius_m * normal;
    moved = true;
  }
  for (const BoxCollider& box : colliders.boxes) {
    const double distance_m = signedDistance(box, point_m);
    if (distance_m >= 0.0) continue;
    point_m -= distance_m * boxNormal(box, point_m);
    moved = true;
  }
  return moved;
}

Eigen::Vector3d collisionResponse(const Eigen::Vector3d& relative_velocity_m_per_s, const Eigen::Vector3d& normal,
                                  const ContactOptions& options) {
  const double normal_speed = relative_velocity_m_per_s.dot(normal);  // < 0: approaching
  const Eigen::Vector3d tangential = relative_velocity_m_per_s - normal_speed * normal;
  const double normal_change = (1.0 + options.restitution) * -normal_speed;
  const double tangential_speed = tangential.norm();
  // Coulomb: the tangential speed drops by at most mu times the normal velocity change, never reversing.
  const double kept = tangential_speed > 0.0
                          ? std::max(0.0, 1.0 - options.friction * normal_change / tangential_speed)
                          : 0.0;
  return kept * tangential - options.restitution * normal_speed * normal;
}

ContactStats resolveContacts(const ColliderSet& colliders, const ContactOptions& options, double t0_s, double t1_s,
                             const Eigen::VectorXd& inverse_mass_per_kg, const Eigen::Matrix3Xd& previous_positions_m,
                             Eigen::Matrix3Xd& positions_m, Eigen::Matrix3Xd& velocities_m_per_s,
                             const Eigen::Matrix3Xd* forces_N) {
  ContactStats stats;
  const StickInputs stick{forces_N, &inverse_mass_per_kg, t1_s - t0_s};
  for (const PlaneCollider& plane : colliders.planes) {
    resolvePlane(plane, options, stick, inverse_mass_per_kg, previous_positions_m, positions_m, velocities_m_per_s,
                 stats);
  }
  for (const BoxCollider& box : colliders.boxes) {
    resolveBox(box, options, stick, inverse_mass_per_kg, previous_positions_m, positions_m, velocities_m_per_s, stats);
  }
  for (const SphereCollider& sphere : colliders.spheres) {
    resolveSphere(sphere, options, stick, t0_s, t1_s, inverse_mass_per_kg, previous_positions_m, positions_m,
                  velocities_m_per_s, stats);
  }
  return stats;
}

double maxPenetration(const ColliderSet& colliders, double time_s, const Eigen::Matrix3Xd& positions_m) {
  double deepest_m = 0.0;
  for (Eigen::Index i = 0; i < positions_m.cols(); ++i) {
    const Eigen::Vector3d point = positions_m.col(i);
    for (const PlaneCollider& plane : colliders.planes) deepest_m = std::max(deepest_m, -signedDistance(plane, point));
    for (const BoxCollider& box : colliders.boxes) deepest_m = std::max(deepest_m, -signedDistance(box, point));
    for (const SphereCollider& sphere : colliders.spheres) {
      deepest_m = std::max(deepest_m, -signedDistance(sphere, sphere.centerAt(time_s), point));
    }
  }
  return deepest_m;
}

std::string vectorText(const Eigen::Vector3d& v) {
  std::ostringstream text;
  text << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return text.str();
}

namespace {

/// The particles more than depth_m inside a collider whose signed distance `distance` gives, and the
/// deepest of them (m): "N particles, up to D m deep", or "" when none is.
template <typename SignedDistance>
std::string particlesInside(double depth_m, const Eigen::Matrix3Xd& positions_m, const std::vector<std::uint8_t>& active,
                            SignedDistance distance) {
  int count = 0;
  double deepest_m = 0.0;
  for (Eigen::Index i = 0; i < positions_m.cols(); ++i) {
    if (!active.empty() && active[static_cast<std::size_t>(i)] == 0) continue;
    const double inside_m = -distance(Eigen::Vector3d(positions_m.col(i)));
    if (!(inside_m > depth_m)) continue;
    ++count;
    deepest_m = std::max(deepest_m, inside_m);
  }
  if (count == 0) return "";
  std::ostringstream text;
  text << count << (count == 1 ? " particle" : " particles") << ", up to " << deepest_m << " m deep";
  return text.str();
}

}  // namespace

std::string colliderHoldingParticles(const ColliderSet& colliders, double depth_m, double time_s,
                                     const Eigen::Matrix3Xd& positions_m, const std::vector<std::uint8_t>& active) {
  for (std::size_t k = 0; k < colliders.planes.size(); ++k) {
    const PlaneCollider& plane = colliders.planes[k];
    const std::string inside = particlesInside(depth_m, positions_m, active,
                                               [&plane](const Eigen::Vector3d& p) { return signedDistance(plane, p); });
    if (!inside.empty()) {
      std::ostringstream text;
      text << "plane " << k << " (normal " << vectorText(plane.normal) << ", offset " << plane.offset_m << " m) holds "
           << inside;
      return text.str();
    }
  }
  for (std::size_t k = 0; k < colliders.spheres.size(); ++k) {
    const SphereCollider& sphere = colliders.spheres[k];
    const Eigen::Vector3d center_m = sphere.centerAt(time_s);
    const std::string inside = particlesInside(
        depth_m, positions_m, active, [&](const Eigen::Vector3d& p) { return signedDistance(sphere, center_m, p); });
    if (!inside.empty()) {
      std::ostringstream text;
      text << "sphere " << k << " (centre " << vectorText(center_m) << " m" << ", radius " << sphere.radius_m << " m) holds "
           << inside;
      return text.str();
    }
  }
  for (std::size_t k = 0; k < colliders.boxes.size(); ++k) {
    const BoxCollider& box = colliders.boxes[k];
    const std::string inside = particlesInside(depth_m, positions_m, active,
                                               [&box](const Eigen::Vector3d& p) { return signedDistance(box, p); });
    if (!inside.empty()) {
      return "box " + std::to_string(k) + " (min " + vectorText(box.min_m) + " m, max " + vectorText(box.max_m) +
             " m) holds " + inside;
    }
  }
  return "";
}

namespace {

/// Most samples the sweep takes along one particle's path in a shape's frame.
constexpr int kMaxSweepSamples = 64;
/// Bisection steps that place a swept particle's entry point (the path's length / 2^20 off at most).
constexpr int kEntryBisections = 20;

/// The local path start + s (end - start), s in [0, 1], against a shape: the first sample where it is
/// deeper than the band, or -1 if none is.
double firstDeepSample(const FrameCollider& collider, const Eigen::Vector3d& start, const Eigen::Vector3d& end,
                       double depth_m) {
  const double length_m = (end - start).norm();
  const int samples =
      std::clamp(static_cast<int>(std::ceil(2.0 * length_m / std::max(collider.thickness_m(), kTinyLength_m))), 1,
                 kMaxSweepSamples);
  Eigen::Vector3d normal;
  for (int k = 1; k <= samples; ++k) {
    const double s = static_cast<double>(k) / samples;
    if (!notInside(shapeSignedDistance(collider, start + s * (end - start), &normal), depth_m)) return s;
  }
  return -1.0;
}

/// The point where the path first meets the surface, between s = 0 (not inside) and s_in (inside).
Eigen::Vector3d entryPoint(const FrameCollider& collider, const Eigen::Vector3d& start, const Eigen::Vector3d& end,
                           double s_in) {
  double outside = 0.0;
  double inside = s_in;
  Eigen::Vector3d normal;
  for (int k = 0; k < kEntryBisections; ++k) {
    const double middle = 0.5 * (outside + inside);
    if (shapeSignedDistance(collider, start + middle * (end - start), &normal) < 0.0) {
      inside = middle;
    } else {
      outside = middle;
    }
  }
  return start + outside * (end - start);
}

}  // namespace

ContactStats resolveFrameColliders(const std::vector<FrameCollider>& colliders,
                                   const std::vector<FrameColliderTrack>& tracks, const ContactOptions& options,
                                   double t0_s, double t1_s, const Eigen::VectorXd& inverse_mass_per_kg,
                                   const Eigen::Matrix3Xd& previous_positions_m, Eigen::Matrix3Xd& positions_m,
                                   Eigen::Matrix3Xd& velocities_m_per_s) {
  ContactStats stats;
  const double depth_m = options.depth_m;
  for (std::size_t c = 0; c < colliders.size() && c < tracks.size(); ++c) {
    if (!tracks[c].seen) continue;
    const FrameCollider& collider = colliders[c];
    const PoseTrack& track = tracks[c].track;
    const Pose pose0 = track.atTime(t0_s);
    const Pose pose1 = track.atTime(t1_s);
    const Twist twist = track.twist();
    const Eigen::Matrix3d to_local0 = pose0.orientation.toRotationMatrix().transpose();
    const Eigen::Matrix3d to_local1 = pose1.orientation.toRotationMatrix().transpose();
    const Eigen::Matrix3d to_world1 = pose1.orientation.toRotationMatrix();
    // Anything further than this from the shape's origin, at both ends of the substep and along the path,
    // cannot touch it.
    const double reach_m = collider.boundingRadius_m() + depth_m;
    for (Eigen::Index i = 0; i < positions_m.cols(); ++i) {
      if (inverse_mass_per_kg[i] == 0.0) continue;
      const Eigen::Vector3d start = to_local0 * (previous_positions_m.col(i) - pose0.position_m);
      const Eigen::Vector3d end = to_local1 * (positions_m.col(i) - pose1.position_m);
      const Eigen::Vector3d path = end - start;
      const double along = path.squaredNorm() > 0.0 ? std::clamp(-start.dot(path) / path.squaredNorm(), 0.0, 1.0) : 0.0;
      if ((start + along * path).norm() > reach_m) continue;  // the whole path passes outside the bound

      Eigen::Vector3d start_normal;
      Eigen::Vector3d end_normal;
      const double start_distance = shapeSignedDistance(collider, start, &start_normal);
      const double end_distance = shapeSignedDistance(collider, end, &end_normal);
      const double deep_at = notInside(start_distance, depth_m) ? firstDeepSample(collider, start, end, depth_m) : -1.0;
      const bool tunnelled = deep_at >= 0.0 && notInside(end_distance, depth_m);
      Crossing crossing = classifyDeep(start_distance, end_distance, depth_m);
      if (tunnelled) crossing = Crossing::kSwept;
      if (crossing == Crossing::kNone && end_distance > depth_m) continue;

      Eigen::Vector3d surface_local;
      Eigen::Vector3d normal_local;
      const bool same_side = end_normal.dot(start_normal) > 0.0;
      if (crossing == Crossing::kSwept && deep_at >= 0.0 && (start_distance > depth_m || !same_side)) {
        // Back to where it met the surface, so it cannot come out on the far side (a link at speed often
        // carries a particle past its core within one substep, where the nearest surface is the wrong one).
        // One that started in the band (resting on the link) and is still on that side is pushed to the
        // nearest surface instead, so that it can slide and friction decides whether it is carried.
        const Eigen::Vector3d entry = entryPoint(collider, start, end, deep_at);
        const double entry_distance = shapeSignedDistance(collider, entry, &normal_local);
        surface_local = entry - entry_distance * normal_local;
      } else {
        normal_local = end_normal;
        surface_local = end - end_distance * end_normal;
      }
      const Eigen::Vector3d normal = to_world1 * normal_local;
      const Eigen::Vector3d surface_m = pose1.transform(surface_local);
      const Eigen::Vector3d surface_velocity = twist.pointVelocity(surface_m - pose1.position_m);
      const bool approaching = respond(normal, surface_velocity, options, velocities_m_per_s.col(i));
      if (crossing != Crossing::kNone || (approaching && end_distance < 0.0)) positions_m.col(i) = surface_m;
      count(crossing, stats);
      if (crossing == Crossing::kNone && approaching) ++stats.band_collisions;
    }
  }
  return stats;
}

double maxFrameColliderPenetration(const std::vector<FrameCollider>& colliders,
                                   const std::vector<FrameColliderTrack>& tracks, double time_s,
                                   const Eigen::Matrix3Xd& positions_m) {
  double deepest_m = 0.0;
  for (std::size_t c = 0; c < colliders.size() && c < tracks.size(); ++c) {
    if (!tracks[c].seen) continue;
    const Pose pose = tracks[c].track.atTime(time_s);
    const Eigen::Matrix3d to_local = pose.orientation.toRotationMatrix().transpose();
    Eigen::Vector3d normal;
    for (Eigen::Index i = 0; i < positions_m.cols(); ++i) {
      const double distance_m =
          shapeSignedDistance(colliders[c], to_local * (positions_m.col(i) - pose.position_m), &normal);
      deepest_m = std::max(deepest_m, -distance_m);
    }
  }
  return deepest_m;
}

}  // namespace cloth_sim::core
