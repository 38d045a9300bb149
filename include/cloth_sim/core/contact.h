// Collisions (paper §4): planes, spheres and axis-aligned boxes, with the paper's contact band.
//
// For a particle, P is the signed distance to the collider's surface (positive outside) and Depth the
// band half-width:
//   P < -Depth           penetrated: the particle is moved back onto the surface (P = 0) and its
//                        velocity gets the collision response;
//   -Depth <= P <= Depth contact band: a collision only if the velocity points into the collider; then
//                        the response, and a particle already under the surface is lifted onto it;
//   P > Depth            free.
// Response (§4.3): split the velocity relative to the collider at the contact normal, scale the normal
// part by (1 - Kr) = -e, and apply Coulomb friction to the tangential part with the normal impulse.
// So after resolveContacts no particle is deeper than Depth inside any collider ("inside" below means
// beyond the band).
//
// Fast motion: each resolver also gets the positions at the start of the substep and sweeps the
// segment between them (in the collider's moving frame for spheres), so a particle that would cross a
// thin box or a fast sphere within one substep is caught at its entry point and counted.
#pragma once

#include "cloth_sim/core/frame_colliders.h"
#include "cloth_sim/core/kinematics.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// A plane n . x + d = 0 with unit normal n pointing to the free side (world frame).
struct PlaneCollider {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset_m = 0.0;  ///< d
};

/// A sphere whose centre moves as c(t) = c0 + v t + A sin(2 pi t / T): static, linear, or swinging (the
/// closed form is ScriptedMotion's, kinematics.h).
struct SphereCollider {
  Eigen::Vector3d center_m = Eigen::Vector3d::Zero();               ///< c0, world frame
  double radius_m = 0.1;
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();       ///< v
  Eigen::Vector3d oscillation_amplitude_m = Eigen::Vector3d::Zero();  ///< A
  double oscillation_period_s = 1.0;                                 ///< T

  /// The centre's motion (no travel): what centerAt and velocityAt evaluate, and the sphere's body.
  ScriptedMotion motion() const;
  Eigen::Vector3d centerAt(double time_s) const { return motion().positionAt(time_s); }
  Eigen::Vector3d velocityAt(double time_s) const { return motion().velocityAt(time_s); }
};

/// An axis-aligned box (a table, a step), static, world frame.
struct BoxCollider {
  Eigen::Vector3d min_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_m = Eigen::Vector3d::Ones();
};

struct ContactOptions {
  double depth_m = 0.002;    ///< band half-width, the paper's Depth
  double restitution = 0.0;  ///< e = Kr - 1, in [0, 1]
  double friction = 0.3;     ///< Coulomb coefficient mu, >= 0
};

/// What happened in one resolveContacts call (counts of particles).
struct ContactStats {
  int band_collisions = 0;  ///< in the band and approaching: velocity response
  int penetrations = 0;     ///< found beyond the band and projected back
  int swept_hits = 0;       ///< started outside or in the band, crossed the surface within the substep,
                            ///< caught by the sweep
  ContactStats& operator+=(const ContactStats& other);
};

/// Signed distance from a point to each collider's surface, m (positive outside).
double signedDistance(const PlaneCollider& plane, const Eigen::Vector3d& point_m);
double signedDistance(const SphereCollider& sphere, const Eigen::Vector3d& center_m, const Eigen::Vector3d& point_m);
double signedDistance(const BoxCollider& box, const Eigen::Vector3d& point_m);

/// The response of §4.3 on a velocity relative to the collider, for unit normal n (out of the collider).
/// Only call it when the relative velocity points into the collider.
Eigen::Vector3d collisionResponse(const Eigen::Vector3d& relative_velocity_m_per_s, const Eigen::Vector3d& normal,
                                  const ContactOptions& options);

/// The colliders of a scene as they stand at one instant.
struct ColliderSet {
  std::vector<PlaneCollider> planes;
  std::vector<SphereCollider> spheres;
  std::vector<BoxCollider> boxes;
  /// Robot links on tf frames (frame_colliders.h); their poses are inputs (ClothInputs::frame_colliders).
  std::vector<FrameCollider> frames;
  bool empty() const { return planes.empty() && spheres.empty() && boxes.empty() && frames.empty(); }
};

/// Resolves contacts after a substep from t0 to t1: positions/velocities are the substep's result,
/// previous_positions_m its start. Particles with zero inverse mass (pinned) are left alone. With
/// forces_N, the forces on each particle at the substep's end (N, world frame), a particle that static
/// friction holds (stopped along the surface by the response, and pushed along it by less than friction
/// x the normal force) is also put back where it started along the surface: without them (null) a
/// particle held by static friction still slides the step's own F h^2 / m each substep (contact.cpp).
ContactStats resolveContacts(const ColliderSet& colliders, const ContactOptions& options, double t0_s, double t1_s,
                             const Eigen::VectorXd& inverse_mass_per_kg, const Eigen::Matrix3Xd& previous_positions_m,
                             Eigen::Matrix3Xd& positions_m, Eigen::Matrix3Xd& velocities_m_per_s,
                             const Eigen::Matrix3Xd* forces_N = nullptr);

/// Resolves contacts with colliders on moving, turning frames after a substep from t0 to t1 (the same
/// band, response and friction as resolveContacts). Each particle's substep is seen in the shape's own
/// frame, where the shape stands still: it moves from pose(t0)^-1 x0 to pose(t1)^-1 x1. A particle that
/// ends inside is pushed out to the nearest surface point; one whose path crossed the shape within the
/// substep (sampled at half the shape's thickness) or reached its far side goes back to where it entered.
/// So no free particle ends a substep deeper than the band inside a frame collider, at any link speed.
/// Velocities are made relative to the surface point's velocity (the track's twist). Unseen tracks and
/// particles with zero inverse mass are left alone.
ContactStats resolveFrameColliders(const std::vector<FrameCollider>& colliders,
                                   const std::vector<FrameColliderTrack>& tracks, const ContactOptions& options,
                                   double t0_s, double t1_s, const Eigen::VectorXd& inverse_mass_per_kg,
                                   const Eigen::Matrix3Xd& previous_positions_m, Eigen::Matrix3Xd& positions_m,
                                   Eigen::Matrix3Xd& velocities_m_per_s);
/// The deepest a particle sits inside any seen frame collider at time_s, m (0 when none is inside).
double maxFrameColliderPenetration(const std::vector<FrameCollider>& colliders,
                                   const std::vector<FrameColliderTrack>& tracks, double time_s,
                                   const Eigen::Matrix3Xd& positions_m);

/// Moves a point that is inside a plane, sphere (at time_s) or box onto its surface (position only, no
/// velocity change); true if it moved. Frame colliders are not considered. What another position
/// correction (self-collision) uses to keep a particle it pushed out of the table it rests on.
bool liftOntoSurfaces(const ColliderSet& colliders, double time_s, Eigen::Ref<Eigen::Vector3d> point_m);

/// The smallest signed distance from a point to a plane, sphere (at time_s) or box, m (infinity without
/// them; frame colliders are not considered), and that surface's outward unit normal there if `normal`.
double nearestSurfaceDistance_m(const ColliderSet& colliders, double time_s, const Eigen::Vector3d& point_m,
                                Eigen::Vector3d* normal = nullptr);

/// The deepest a particle sits inside any collider, m (negative signed distance); 0 when none is inside.
double maxPenetration(const ColliderSet& colliders, double time_s, const Eigen::Matrix3Xd& positions_m);

/// "(x, y, z)": a point or a direction in an error (the unit is the caller's).
std::string vectorText(const Eigen::Vector3d& v);

/// The first plane, sphere (at time_s) or box, in that order, that holds particles of positions_m more
/// than depth_m inside it (those `active` marks, or all when it is empty): its kind, index and shape, how
/// many it holds and how deep the deepest is, as words for an error; "" when none does. Frame colliders
/// are not considered (their poses arrive later).
std::string colliderHoldingParticles(const ColliderSet& colliders, double depth_m, double time_s,
                                     const Eigen::Matrix3Xd& positions_m, const std::vector<std::uint8_t>& active);

}  // namespace cloth_sim::core
