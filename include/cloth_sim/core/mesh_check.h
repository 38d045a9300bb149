// A checker of a cloth mesh's integrity (issue 15): which pairs of triangles pass through each other.
// It is what "the cloth never passes through itself" is tested against, so it is written to be simple
// and exact, and on its own (not on self-collision's broad phase): a uniform grid over the triangles'
// bounding boxes finds candidate pairs, each tested edge against triangle once. The simulation's guard
// also asks it, in frames that take self-collision's guarantee out of force (Simulation::computeFrame):
// about 1.5 ms on a folded 64 x 64 towel.
#pragma once

#include <Eigen/Core>

#include <utility>
#include <vector>

namespace cloth_sim::core {

/// Whether the segment a -> b passes through the triangle (p, q, r): they meet at a point inside the
/// triangle (barycentric coordinates all >= 0) and on the segment (parameter in [0, 1]). A segment lying
/// in the triangle's plane never counts (it touches, it does not pass through).
bool segmentCrossesTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& q, const Eigen::Vector3d& r);

/// The pairs of triangles (indices into the list, i < j, in increasing order) that share no particle and
/// where an edge of one passes through the other. `triangles` holds three particle indices per triangle
/// (ClothGrid::triangles), `positions_m` the particles (3 x N, any frame).
std::vector<std::pair<int, int>> crossingTrianglePairs(const std::vector<int>& triangles,
                                                       const Eigen::Matrix3Xd& positions_m);

}  // namespace cloth_sim::core
