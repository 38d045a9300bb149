#include "cloth_sim/core/mesh_check.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace cloth_sim::core {

namespace {

/// Below this |det| the segment is parallel to the triangle's plane (relative to the edge lengths cubed).
constexpr double kParallelTolerance = 1e-12;

struct Box {
  Eigen::Vector3d min;
  Eigen::Vector3d max;
};

std::int64_t cellKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  // 21 bits per axis, offset so that negative cells map into the range: plenty for a cloth's extent.
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::int64_t kMask = (std::int64_t{1} << 21) - 1;
  return (((x + kOffset) & kMask) << 42) | (((y + kOffset) & kMask) << 21) | ((z + kOffset) & kMask);
}

bool shareParticle(const int* a, const int* b) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (a[i] == b[j]) return true;
    }
  }
  return false;
}

Box triangleBox(const std::vector<int>& triangles, const Eigen::Matrix3Xd& positions_m, int t) {
  Box box;
  box.min = box.max = positions_m.col(triangles[3 * t]);
  for (int c = 1; c < 3; ++c) {
    box.min = box.min.cwiseMin(positions_m.col(triangles[3 * t + c]));
    box.max = box.max.cwiseMax(positions_m.col(triangles[3 * t + c]));
  }
  return box;
}

bool boxesOverlap(const Box& a, const Box& b) {
  return !((a.max.array() < b.min.array()).any() || (b.max.array() < a.min.array()).any());
}

bool trianglesCross(const Eigen::Matrix3Xd& x, const int* a, const int* b) {
  for (int e = 0; e < 3; ++e) {
    if (segmentCrossesTriangle(x.col(a[e]), x.col(a[(e + 1) % 3]), x.col(b[0]), x.col(b[1]), x.col(b[2]))) return true;
    if (segmentCrossesTriangle(x.col(b[e]), x.col(b[(e + 1) % 3]), x.col(a[0]), x.col(a[1]), x.col(a[2]))) return true;
  }
  return false;
}

}  // namespace

bool segmentCrossesTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& p,
                            const Eigen::Vector3d& q, const Eigen::Vector3d& r) {
  // Moeller-Trumbore with the segment's direction d = b - a: a + t d = p + u (q - p) + v (r - p).
  const Eigen::Vector3d d = b - a;
  const Eigen::Vector3d e1 = q - p;
  const Eigen::Vector3d e2 = r - p;
  const Eigen::Vector3d h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = d.norm() * e1.norm() * e2.norm();
  if (!(std::abs(det) > kParallelTolerance * scale)) return false;
  const double inverse = 1.0 / det;
  const Eigen::Vector3d s = a - p;
  const double u = inverse * s.dot(h);
  if (u < 0.0 || u > 1.0) return false;
  const Eigen::Vector3d k = s.cross(e1);
  const double v = inverse * d.dot(k);
  if (v < 0.0 || u + v > 1.0) return false;
  const double t = inverse * e2.dot(k);
  return t >= 0.0 && t <= 1.0;
}

std::vector<std::pair<int, int>> crossingTrianglePairs(const std::vector<int>& triangles,
                                                       const Eigen::Matrix3Xd& positions_m) {
  const int count = static_cast<int>(triangles.size() / 3);
  std::vector<std::pair<int, int>> crossing;
  if (count < 2) return crossing;
  std::vector<Box> boxes(static_cast<std::size_t>(count));
  double longest_m = 0.0;
  for (int t = 0; t < count; ++t) {
    Box& box = boxes[static_cast<std::size_t>(t)];
    box = triangleBox(triangles, positions_m, t);
    longest_m = std::max(longest_m, (box.max - box.min).maxCoeff());
  }
  if (!(longest_m > 0.0) || !std::isfinite(longest_m)) return crossing;
  // Cells the size of the largest triangle's box: each triangle covers at most 2 x 2 x 2 of them.
  const double cell_m = longest_m;
  std::unordered_map<std::int64_t, std::vector<int>> cells;
  for (int t = 0; t < count; ++t) {
    const Box& box = boxes[static_cast<std::size_t>(t)];
    const Eigen::Array3d low = (box.min / cell_m).array().floor();
    const Eigen::Array3d high = (box.max / cell_m).array().floor();
    for (auto x = static_cast<std::int64_t>(low.x()); x <= static_cast<std::int64_t>(high.x()); ++x) {
      for (auto y = static_cast<std::int64_t>(low.y()); y <= static_cast<std::int64_t>(high.y()); ++y) {
        for (auto z = static_cast<std::int64_t>(low.z()); z <= static_cast<std::int64_t>(high.z()); ++z) {
          cells[cellKey(x, y, z)].push_back(t);
        }
      }
    }
  }
  for (const auto& [key, members] : cells) {
    for (std::size_t i = 0; i < members.size(); ++i) {
      for (std::size_t j = i + 1; j < members.size(); ++j) {
        const int a = std::min(members[i], members[j]);
        const int b = std::max(members[i], members[j]);
        const Box& ba = boxes[static_cast<std::size_t>(a)];
        const Box& bb = boxes[static_cast<std::size_t>(b)];
        if (!boxesOverlap(ba, bb)) continue;
        // Two overlapping boxes share every cell from the larger of their low corners on: the pair is
        // tested in that first one only (once, without sorting the candidates).
        const Eigen::Array3d first = (ba.min.cwiseMax(bb.min) / cell_m).array().floor();
        if (cellKey(static_cast<std::int64_t>(first.x()), static_cast<std::int64_t>(first.y()),
                    static_cast<std::int64_t>(first.z())) != key) {
          continue;
        }
        const int* ta = &triangles[static_cast<std::size_t>(3 * a)];
        const int* tb = &triangles[static_cast<std::size_t>(3 * b)];
        if (!shareParticle(ta, tb) && trianglesCross(positions_m, ta, tb)) crossing.emplace_back(a, b);
      }
    }
  }
  // In increasing order, whatever the hash's.
  std::sort(crossing.begin(), crossing.end());
  return crossing;
}

}  // namespace cloth_sim::core
