// Self-collision (issue 15): the cloth never passes through itself.
//
// Method (doc/PHYSICS.md, "Self-collision"): particles are kept at least a thickness h apart, pair by
// pair, after each substep (after the colliders), as in Mueller's hashed particle self-collision;
// particles closer than kExemptRestThicknesses x h on the rest grid are exempt (the springs keep them
// apart). A swept spatial hash (spatial_hash.h) finds the pairs. Then, all on the substep's result, in
// one fixed order:
//   1. response: kResponseSweeps Gauss-Seidel sweeps push every pair closer than h back to h, mass-
//      weighted, along the line between them (along their start direction if they passed each other; a
//      particle on a table or the floor is held by it, and the one above it moves along the surface's
//      normal), each sweep lifting what it pushed into a surface back onto it; then friction between
//      the layers on the pair's relative sliding (Coulomb, bounded by friction x the normal push), and an
//      inelastic velocity change: the pair's approach is removed, with friction on its sliding;
//   2. fail-safe: every pair whose straight path over the substep came closer than kFailSafeFraction x h
//      (and closer than it started) has its free particles put back where the substep started them, at
//      rest, until no such pair is left (it ends: with every free particle back, nothing moved).
// The guarantee: while no triangle edge is longer than kFailSafeFraction x h / kCoverFactor, no two
// triangles whose particles are all further than the exempt distance apart on the rest grid pass through
// each other within a substep (doc/PHYSICS.md has the argument), except where a pin or gripper (a particle
// with no inverse mass) drags the cloth through itself: that is counted (SelfCollisionStats::forced) and
// reported in the frame's warning, not hidden.
#pragma once

#include "cloth_sim/core/contact.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/spatial_hash.h"

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace cloth_sim::core {

/// Scene keys self_collision, self_collision_thickness, self_collision_friction.
struct SelfCollisionOptions {
  bool enabled = false;
  /// The distance layers keep, m; 0: kDefaultThicknessPerDiagonal x the grid cell's diagonal.
  double thickness_m = 0.0;
  double friction = 0.3;  ///< Coulomb coefficient between layers, >= 0
};

/// The default thickness per cell diagonal sqrt(du^2 + dv^2). The fail-safe keeps pairs at least
/// kFailSafeFraction x h apart, and a point of the cloth passing through a triangle comes within
/// kCoverFactor x (its longest edge) of some particle pair across the two layers: so 1.5 diagonals leaves
/// the guarantee in force up to edges 11 % longer than the rest diagonal.
constexpr double kDefaultThicknessPerDiagonal = 1.5;

/// The thickness in force: options.thickness_m, or its default for the grid.
double selfCollisionThickness_m(const SelfCollisionOptions& options, const ClothGrid& grid);

/// What self-collision did in one or more substeps.
struct SelfCollisionStats {
  /// Pairs the broad phase handed to the response (with those of two particles that cannot move, which
  /// its sweeps pass over).
  int candidate_pairs = 0;
  int contacts = 0;         ///< pairs the response pushed apart
  int frozen = 0;           ///< particles the fail-safe put back where their substep started
  /// Pairs the fail-safe could not separate because a particle with no inverse mass (pinned, held by a
  /// gripper) drags the other through: the cloth was pulled through itself by a hand.
  int forced = 0;
  /// Longest triangle edge / the longest for which the guarantee holds (above 1: not guaranteed), after
  /// the last substep.
  double stretch_ratio = 0.0;
  /// The largest stretch_ratio after any of the substeps.
  double largest_stretch_ratio = 0.0;
  /// Triangle pairs that passed through each other in a frame that took the guarantee out of force
  /// (largest_stretch_ratio above 1), as crossingTrianglePairs counts them after the frame and not before,
  /// where the guard's finest computation of the frame did not prevent it (Simulation::computeFrame).
  int crossed = 0;
  SelfCollisionStats& operator+=(const SelfCollisionStats& other);
};

/// Self-collision's broad phase, response and fail-safe for one grid, with its scratch memory. What it
/// carries from one call to the next (the candidate list) is a cache that no result depends on (a
/// restored run continues bit for bit).
class SelfCollision {
 public:
  /// Pairs closer than this many thicknesses on the rest grid are exempt. Not 1: the cloth between two
  /// particles an arc s apart around a fold is a chord shorter than s, so pairs just over h apart on the
  /// grid could never be h apart in a fold (they fought it and crept). A fold of radius h / 2 puts particles
  /// pi h / 2 apart on the grid h apart in space: 1.6 just leaves room for that (pi / 2 = 1.571).
  static constexpr double kExemptRestThicknesses = 1.6;
  /// Gauss-Seidel sweeps of the response per substep.
  static constexpr int kResponseSweeps = 4;
  /// The fail-safe keeps every exempt-free pair at least this fraction of the thickness apart.
  static constexpr double kFailSafeFraction = 0.8;
  /// Any point on an edge of one triangle that lies in another is within this times the longest edge of
  /// the two of a particle of each (half an edge, plus the farthest a point of a triangle is from its
  /// nearest vertex, at most the longest edge / sqrt(3)).
  static constexpr double kCoverFactor = 0.5 + 0.57735026918962576;
  /// The stretch ratio (SelfCollisionStats::stretch_ratio) up to which the guarantee holds.
  static constexpr double kGuaranteedStretchRatio = 1.0;

  /// Resolves self-contacts after a substep ending at time_s: start_m are the particles at the
  /// substep's start (free of self-contact as this leaves them), positions and velocities its result
  /// (after the colliders). Particles with zero inverse mass are never moved.
  SelfCollisionStats resolve(const ClothGrid& grid, const SelfCollisionOptions& options, const ColliderSet& colliders,
                             const ContactOptions& contact, double time_s, const Eigen::VectorXd& inverse_mass_per_kg,
                             const Eigen::Matrix3Xd& start_m, Eigen::Matrix3Xd& positions_m,
                             Eigen::Matrix3Xd& velocities_m_per_s);

 private:
  /// Reach of the response's candidates, in thicknesses. A sweep pushes a pair that is within h along its
  /// normal: the line between the two (then under h apart), a surface's normal within 45 degrees of that
  /// line (under sqrt(2) h apart, and under h along a floor's axes), or, for two that passed each other
  /// in the substep, their starting direction. The margin over h is for pairs that other pushes of the
  /// same substep's sweeps bring within h. Measured with the reach at 1.5 (2026-11-27): of 4.9 million
  /// pushes over the 64 x 64 and 128 x 128 folds, the fold with late hands, the 32 x 32 and 64 x 64
  /// piles, the thrown layers and the twisted strips, 167 were of pairs whose boxes lay more than 1.2 h
  /// apart (162 in the 64 x 64 pile) and 1 more than 1.35 h (in the 64-row twisted strip). At 1.35 the
  /// folds from 24 x 24 to 128 x 128 and the piles give the same bits as at 1.5, and the strip is refined
  /// for a crossing in one frame instead of two. Only layers that two grippers drag through each other
  /// push pairs from further (282 of 97,000 pushes). A pair left out is pushed in the next substep, and
  /// the fail-safe, which finds its own pairs when the response has moved particles further than its
  /// boxes allow, holds the guarantee meanwhile. At 1.5 a folded 64 x 64 towel at rest had 2.3 times the
  /// candidates (most of the extra ones pairs of one layer just past the exempt distance, diagonally,
  /// which its springs keep apart), and the fold cost 7 % more.
  static constexpr double kResponseReach = 1.35;
  /// The wider list's slack, in thicknesses: it serves while no particle is further than this (along any
  /// axis) from where the list was built, at the start and the end of a substep. At 0.5 the list held
  /// three times the pairs the response needs, and rebuilding it while the fold carries its half cost
  /// more than the reuse saved (64 x 64: 25.4 ms a carrying frame, 22.9 at 0.25); under 0.15 a resting
  /// towel, whose lower layer the step sinks a fall's worth into the floor, rebuilt it every substep.
  static constexpr double kListSlack = 0.25;
  /// A candidate pair whose squared distance is above this many squared thicknesses (and which has not
  /// passed through itself) is at least a thickness apart along the response's normal: over 2, with room
  /// for surface normals that are unit vectors to 1e-6 only.
  static constexpr double kFarSquaredThicknesses = 2.01;
  /// The share of the room between the response's and the fail-safe's boxes that the response's pushes
  /// may use up while the fail-safe still takes its pairs from the response's (below 1: rounding).
  static constexpr double kInsideFraction = 0.9;
  /// Fills *pairs with exactly what finder_.find(start, end, reach, apart) would (the same pairs in the
  /// same order, so results do not depend on when the list was built: save/restore stays bit-exact),
  /// taken from a wider list (a Verlet list) while it is valid, else from a new one.
  template <typename Apart>
  void candidatePairs(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m,
                      double thickness_m, const Apart& apart, std::vector<std::pair<int, int>>* pairs);
  /// Whether every particle of positions_m is within the slack of where the list was built.
  bool withinSlack(const Eigen::Matrix3Xd& positions_m, double slack_m) const;

  SweptPairFinder finder_;
  std::vector<std::pair<int, int>> list_pairs_;  ///< the wider list: apart pairs within its reach
  Eigen::Matrix3Xd list_positions_m_;            ///< where it was built
  double list_thickness_m_ = 0.0;                ///< for which thickness (0: none built)
  std::vector<std::pair<int, int>> pairs_;
  Eigen::Matrix3Xd after_step_m_;     ///< the substep's result before the response moved it
  Eigen::VectorXd supported_weight_;  ///< inverse mass, 0 for a particle a table or the floor holds
  Eigen::Matrix3Xd surface_normals_;  ///< for those, the surface's outward normal
  /// A pair the response pushed: how far along its normal in all (m), and the normal of its last push.
  struct Contact {
    int pair = 0;  ///< index in pairs_
    double pushed_m = 0.0;
    Eigen::Vector3d normal;
  };
  std::vector<Contact> contacts_;
  std::vector<int> contact_of_;  ///< per pair: its index in contacts_, -1 if not pushed
  std::vector<int> row_of_;  ///< per particle: its row and column on the grid
  std::vector<int> col_of_;
  /// Response sweeps: per particle, the clock after its last change (0: no sweep has pushed it, so it is
  /// not lifted back onto a surface either).
  std::vector<int> moved_at_;
  std::vector<int> checked_at_;  ///< per pair: 1 + the clock when a sweep last checked it
  std::vector<char> frozen_;
};

/// Self-collision's stretch ratio for particles at positions_m and thickness h: the longest triangle edge
/// over the longest for which the guarantee holds (SelfCollision::kFailSafeFraction x h / kCoverFactor).
/// Above 1 the no-crossing guarantee is not in force.
double selfCollisionStretchRatio(const ClothGrid& grid, double thickness_m, const Eigen::Matrix3Xd& positions_m);

/// The closest two points moving in straight lines come: a from a0 to a1, b from b0 to b1, m.
double closestApproach_m(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                         const Eigen::Vector3d& b1);

}  // namespace cloth_sim::core
