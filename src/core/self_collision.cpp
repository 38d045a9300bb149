#include "cloth_sim/core/self_collision.h"

#include <algorithm>
#include <cmath>

namespace cloth_sim::core {

namespace {

/// Below this (relative to the thickness) a direction between two particles is undefined.
constexpr double kTinyFraction = 1e-9;

/// The longest edge of any triangle, m (the shear diagonals and the structural edges).
double longestTriangleEdge_m(const ClothGrid& grid, const Eigen::Matrix3Xd& positions_m) {
  double longest_squared = 0.0;
  const std::vector<int>& t = grid.triangles;
  for (std::size_t k = 0; k + 2 < t.size(); k += 3) {
    for (int e = 0; e < 3; ++e) {
      const int a = t[k + e];
      const int b = t[k + (e + 1) % 3];
      longest_squared = std::max(longest_squared, (positions_m.col(a) - positions_m.col(b)).squaredNorm());
    }
  }
  return std::sqrt(longest_squared);
}

}  // namespace

double selfCollisionThickness_m(const SelfCollisionOptions& options, const ClothGrid& grid) {
  if (options.thickness_m > 0.0) return options.thickness_m;
  // The cell's diagonal on the rest grid (particles 0 and cols + 1; a single row or column: its spacing).
  const int diagonal = grid.rows > 1 && grid.cols > 1 ? grid.cols + 1 : 1;
  const double diagonal_m = (grid.rest_positions_m.col(diagonal) - grid.rest_positions_m.col(0)).norm();
  return kDefaultThicknessPerDiagonal * diagonal_m;
}

SelfCollisionStats& SelfCollisionStats::operator+=(const SelfCollisionStats& other) {
  candidate_pairs += other.candidate_pairs;
  contacts += other.contacts;
  frozen += other.frozen;
  forced += other.forced;
  stretch_ratio = other.stretch_ratio;  // the latest substep's
  largest_stretch_ratio = std::max(largest_stretch_ratio, other.largest_stretch_ratio);
  crossed += other.crossed;
  return *this;
}

double closestApproach_m(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& b0,
                         const Eigen::Vector3d& b1) {
  const Eigen::Vector3d start = b0 - a0;
  const Eigen::Vector3d change = (b1 - a1) - start;
  const double a = change.squaredNorm();
  const double s = a > 0.0 ? std::clamp(-start.dot(change) / a, 0.0, 1.0) : 0.0;
  return (start + s * change).norm();
}

bool SelfCollision::withinSlack(const Eigen::Matrix3Xd& positions_m, double slack_m) const {
  return (positions_m - list_positions_m_).cwiseAbs().maxCoeff() <= slack_m;
}

template <typename Apart>
void SelfCollision::candidatePairs(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m,
                                   double thickness_m, const Apart& apart, std::vector<std::pair<int, int>>* pairs) {
  // A pair whose boxes (start and end, grown by reach / 2) overlap has boxes around the list's positions,
  // grown by reach / 2 + slack, that overlap too, while every particle is within the slack of them: so a
  // list built with reach + 2 slack holds every pair find would give, for any reach up to the response's.
  const double slack_m = kListSlack * thickness_m;
  const bool valid = list_thickness_m_ == thickness_m && list_positions_m_.cols() == start_m.cols() &&
                     withinSlack(start_m, slack_m) && withinSlack(end_m, slack_m);
  if (!valid) {
    if ((end_m - start_m).cwiseAbs().maxCoeff() > slack_m) {  // moving too far for any list: hash directly
      list_thickness_m_ = 0.0;
      finder_.find(start_m, end_m, reach_m, apart, pairs);
      return;
    }
    list_positions_m_ = start_m;
    list_thickness_m_ = thickness_m;
    finder_.find(start_m, start_m, (kResponseReach + 2.0 * kListSlack) * thickness_m, apart, &list_pairs_);
  }
  finder_.setBoxes(start_m, end_m, reach_m);
  // The list holds apart pairs only. Written without a branch on the overlap, which about a third of the
  // list's pairs pass (at rest): unpredictable, it cost more than the test.
  pairs->resize(list_pairs_.size());
  std::size_t kept = 0;
  for (const std::pair<int, int>& pair : list_pairs_) {
    (*pairs)[kept] = pair;
    kept += finder_.boxesOverlap(pair.first, pair.second) ? 1 : 0;
  }
  pairs->resize(kept);
}

SelfCollisionStats SelfCollision::resolve(const ClothGrid& grid, const SelfCollisionOptions& options,
                                          const ColliderSet& colliders, const ContactOptions& contact, double time_s,
                                          const Eigen::VectorXd& inverse_mass_per_kg, const Eigen::Matrix3Xd& start_m,
                                          Eigen::Matrix3Xd& positions_m, Eigen::Matrix3Xd& velocities_m_per_s) {
  SelfCollisionStats stats;
  const double thickness_m = selfCollisionThickness_m(options, grid);
  const double tiny_m = kTinyFraction * thickness_m;
  // A particle resting on a table or the floor (within the contact band) is held by it: a pair pushes
  // only its other particle (else the floor pushed the lower layer back up into the upper one every
  // step, and the two crept).
  supported_weight_ = inverse_mass_per_kg;
  surface_normals_.resize(3, grid.particleCount());
  if (!colliders.empty()) {
    for (int i = 0; i < grid.particleCount(); ++i) {
      Eigen::Vector3d normal;
      if (nearestSurfaceDistance_m(colliders, time_s, positions_m.col(i), &normal) > contact.depth_m) continue;
      supported_weight_[i] = 0.0;
      surface_normals_.col(i) = normal;
    }
  }
  const Eigen::VectorXd& w = supported_weight_;
  const Eigen::Matrix3Xd& rest = grid.rest_positions_m;
  const int count = grid.particleCount();
  // Neighbours on the rest grid are exempt (the springs keep them apart); the response's sweeps pass over
  // two particles neither of which can move.
  const double exempt_m = SelfCollision::kExemptRestThicknesses * thickness_m;
  const double exempt_squared = exempt_m * exempt_m;
  // On the rest grid (flat, orthonormal axes) two particles are (dc du, dr dv) apart: no memory read.
  const double du_squared = (rest.col(std::min(1, count - 1)) - rest.col(0)).squaredNorm();
  const double dv_squared = (rest.col(std::min(grid.cols, count - 1)) - rest.col(0)).squaredNorm();
  row_of_.resize(static_cast<std::size_t>(count));
  col_of_.resize(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    row_of_[static_cast<std::size_t>(i)] = i / grid.cols;
    col_of_[static_cast<std::size_t>(i)] = i % grid.cols;
  }
  // Captured by value: the broad phase asks this of every pair whose boxes overlap, most of them grid
  // neighbours, and through references each call read the vectors' addresses again.
  const int* const row_of = row_of_.data();
  const int* const col_of = col_of_.data();
  const auto* const active = grid.hasOutline() ? grid.active.data() : nullptr;
  const auto apart = [row_of, col_of, active, du_squared, dv_squared, exempt_squared](int i, int j) {
    const double dr = row_of[j] - row_of[i];
    const double dc = col_of[j] - col_of[i];
    // Particles outside an outline are not cloth: they meet nothing.
    return dr * dr * dv_squared + dc * dc * du_squared > exempt_squared &&
           (active == nullptr || (active[i] != 0 && active[j] != 0));
  };
  // 1. Response. Its pairs include those of two particles that cannot move (the sweeps pass them over, as
  // pairs on the floor), so that the fail-safe's can be taken from them (below).
  after_step_m_ = positions_m;
  candidatePairs(start_m, positions_m, kResponseReach * thickness_m, thickness_m, apart, &pairs_);
  stats.candidate_pairs = static_cast<int>(pairs_.size());
  // A pair this far apart, and not passed through each other, is at least a thickness apart along any
  // normal the sweep would take (along the line between them, or a resting pair's surface normal, which
  // is within 45 degrees of that line: a gap of at least |now| / sqrt(2)); the sweep skips it before
  // working that normal out. Most candidate pairs are such pairs.
  const double far_squared = kFarSquaredThicknesses * thickness_m * thickness_m;
  // Only the pairs a sweep pushed go on to friction and the velocities: a few thousand of the 10^5 pairs
  // of a folded 64 x 64 towel at rest.
  contacts_.clear();
  contact_of_.assign(pairs_.size(), -1);
  // What a sweep does with a pair depends only on its two particles' positions (and on what does not
  // change over the sweeps): a pair it left alone is left alone again until one of them moves. Most pairs
  // are far apart, and a later sweep passes over them on these two counters instead of their positions.
  // The clock ticks at every change of positions (a push, a pass lifting particles onto surfaces); at
  // most 4 (pairs + 1) ticks a substep.
  int clock = 0;
  moved_at_.assign(count, 0);           // per particle: the clock after its last change (0: not pushed)
  checked_at_.assign(pairs_.size(), 0);  // per pair: 1 + the clock when a sweep last checked it
  for (int sweep = 0; sweep < kResponseSweeps; ++sweep) {
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      const auto [i, j] = pairs_[p];
      if (moved_at_[i] < checked_at_[p] && moved_at_[j] < checked_at_[p]) continue;
      checked_at_[p] = clock + 1;
      const double weight_sum = w[i] + w[j];
      if (weight_sum == 0.0) continue;  // both on the floor (or pinned): it keeps them
      const Eigen::Vector3d was = start_m.col(j) - start_m.col(i);
      const Eigen::Vector3d now = positions_m.col(j) - positions_m.col(i);
      if (now.dot(was) > 0.0 && now.squaredNorm() > far_squared) continue;
      const double was_m = was.norm();
      // Apart along the line between them, unless they passed each other: then back to the side they
      // started on.
      Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
      // One of them lies on a surface and the other is above it (within 45 degrees of the surface's
      // normal): the upper one rests along that normal. Along the line between the two, a push tilted off
      // the normal moved the upper layer sideways with nothing to push back (the surface holds the lower
      // particle), and the whole folded towel slid over the floor at a steady 5 mm/s.
      const bool i_below = w[i] == 0.0 && inverse_mass_per_kg[i] > 0.0;
      const Eigen::Vector3d up = i_below ? Eigen::Vector3d(surface_normals_.col(i)) : Eigen::Vector3d(-surface_normals_.col(j));
      const bool resting = (i_below || (w[j] == 0.0 && inverse_mass_per_kg[j] > 0.0)) &&
                           now.dot(up) >= (now - now.dot(up) * up).norm();
      if (resting) {
        normal = up;
      } else if (now.dot(was) > 0.0 && now.norm() > tiny_m) {
        normal = now.normalized();
      } else if (was_m > tiny_m) {
        normal = was / was_m;
      }
      const double gap_m = now.dot(normal);
      if (gap_m >= thickness_m) continue;
      const Eigen::Vector3d push = (thickness_m - gap_m) * normal;
      positions_m.col(i) -= (w[i] / weight_sum) * push;
      positions_m.col(j) += (w[j] / weight_sum) * push;
      if (contact_of_[p] < 0) {
        contact_of_[p] = static_cast<int>(contacts_.size());
        contacts_.push_back(Contact{static_cast<int>(p), 0.0, normal});
      }
      Contact& contact = contacts_[static_cast<std::size_t>(contact_of_[p])];
      contact.pushed_m += thickness_m - gap_m;
      contact.normal = normal;
      moved_at_[i] = moved_at_[j] = ++clock;
    }
    // What was pushed into a table or the floor goes back onto it; the next sweep pushes the other way.
    if (colliders.empty()) continue;
    ++clock;
    for (int i = 0; i < count; ++i) {
      if (moved_at_[i] > 0 && liftOntoSurfaces(colliders, time_s, positions_m.col(i))) moved_at_[i] = clock;
    }
  }
  // Friction between the layers: the pair's relative sliding over the substep, removed up to
  // friction x the normal push (the position form of Coulomb's law; its velocity follows below).
  // In the pairs' order (the sweeps list them in the order they first pushed them).
  std::sort(contacts_.begin(), contacts_.end(), [](const Contact& a, const Contact& b) { return a.pair < b.pair; });
  stats.contacts = static_cast<int>(contacts_.size());
  for (const Contact& contact : contacts_) {
    const auto [i, j] = pairs_[static_cast<std::size_t>(contact.pair)];
    const Eigen::Vector3d slide = (positions_m.col(j) - start_m.col(j)) - (positions_m.col(i) - start_m.col(i));
    const Eigen::Vector3d tangential = slide - slide.dot(contact.normal) * contact.normal;
    const double length_m = tangential.norm();
    if (length_m <= 0.0) continue;
    const double limit_m = options.friction * contact.pushed_m;
    const Eigen::Vector3d removed = length_m <= limit_m ? tangential : Eigen::Vector3d(tangential * (limit_m / length_m));
    const double weight_sum = w[i] + w[j];
    positions_m.col(i) += (w[i] / weight_sum) * removed;
    positions_m.col(j) -= (w[j] / weight_sum) * removed;
  }
  // Velocities: an inelastic contact. The pair's approach along its normal is removed (the push itself adds
  // no speed: a layer resting on another stays at rest instead of being bounced off it every step), and
  // Coulomb friction takes up to friction x that change off their relative sliding. The impulse that does
  // it is solved with a particle on the floor held (the other stops), and the floor's particle then takes
  // the reaction with its own mass: the floor absorbs it in the next step, so it carries the upper
  // layer's weight and its friction holds both layers (without the reaction the lower layer slid out from
  // under the upper one; with the pair's masses shared the upper layer never came to rest).
  const Eigen::VectorXd& true_weight = inverse_mass_per_kg;
  for (const Contact& contact : contacts_) {
    const auto [i, j] = pairs_[static_cast<std::size_t>(contact.pair)];
    const double weight_sum = w[i] + w[j];
    const Eigen::Vector3d& normal = contact.normal;
    const Eigen::Vector3d relative = velocities_m_per_s.col(j) - velocities_m_per_s.col(i);
    const double approach = std::min(0.0, relative.dot(normal));
    const Eigen::Vector3d sliding = relative - relative.dot(normal) * normal;
    const double sliding_speed = sliding.norm();
    Eigen::Vector3d change = -approach * normal;  // what the pair's relative velocity gains
    if (sliding_speed > 0.0) change -= std::min(sliding_speed, -options.friction * approach) / sliding_speed * sliding;
    const Eigen::Vector3d impulse = change / weight_sum;  // kg m/s, on j (and its opposite on i)
    velocities_m_per_s.col(i) -= (w[i] > 0.0 ? w[i] : true_weight[i]) * impulse;
    velocities_m_per_s.col(j) += (w[j] > 0.0 ? w[j] : true_weight[j]) * impulse;
  }

  // 2. Fail-safe: no pair may come closer than kFailSafeFraction h (or than it started) on its path.
  const double floor_m = kFailSafeFraction * thickness_m;
  // Pairs of two pins or gripped particles too: nothing can stop them, but their crossing is counted. The
  // fail-safe's boxes (reach floor_m) lie inside the response's (reach kResponseReach h) while no particle
  // has moved, along any axis, further than half the difference of the two reaches since the response's
  // pairs were found: then its pairs are those of the response whose boxes overlap, in the same order,
  // without another pass over the list.
  const double inside_m = kInsideFraction * 0.5 * (kResponseReach - kFailSafeFraction) * thickness_m;
  if ((positions_m - after_step_m_).cwiseAbs().maxCoeff() <= inside_m) {
    finder_.setBoxes(start_m, positions_m, floor_m);
    const auto outside = [this](const std::pair<int, int>& pair) {
      return !finder_.boxesOverlap(pair.first, pair.second);
    };
    pairs_.erase(std::remove_if(pairs_.begin(), pairs_.end(), outside), pairs_.end());
  } else {
    candidatePairs(start_m, positions_m, floor_m, thickness_m, apart, &pairs_);
  }
  frozen_.assign(count, 0);
  bool changed = true;
  std::vector<char> forced(pairs_.size(), 0);
  while (changed) {
    changed = false;
    for (std::size_t p = 0; p < pairs_.size(); ++p) {
      const auto [i, j] = pairs_[p];
      const double limit_m = std::min(floor_m, (start_m.col(j) - start_m.col(i)).norm()) - tiny_m;
      if (closestApproach_m(start_m.col(i), positions_m.col(i), start_m.col(j), positions_m.col(j)) >= limit_m) continue;
      bool froze = false;
      for (const int k : {i, j}) {
        if (inverse_mass_per_kg[k] == 0.0 || frozen_[k]) continue;
        positions_m.col(k) = start_m.col(k);
        frozen_[k] = 1;
        froze = true;
      }
      if (froze) {
        changed = true;
      } else if (!forced[p]) {
        forced[p] = 1;
        ++stats.forced;
      }
    }
  }

  // 3. What the fail-safe put back stands still.
  for (int i = 0; i < count; ++i) {
    if (!frozen_[i]) continue;
    velocities_m_per_s.col(i).setZero();
    ++stats.frozen;
  }
  stats.stretch_ratio = selfCollisionStretchRatio(grid, thickness_m, positions_m);
  stats.largest_stretch_ratio = stats.stretch_ratio;  // one substep's
  return stats;
}

double selfCollisionStretchRatio(const ClothGrid& grid, double thickness_m, const Eigen::Matrix3Xd& positions_m) {
  const double guaranteed_edge_m = SelfCollision::kFailSafeFraction * thickness_m / SelfCollision::kCoverFactor;
  return longestTriangleEdge_m(grid, positions_m) / guaranteed_edge_m;
}

}  // namespace cloth_sim::core
