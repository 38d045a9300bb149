#include "cloth_sim/core/spatial_hash.h"

#include <algorithm>
#include <cmath>

namespace cloth_sim::core {

namespace {

/// The hash of an integer cell (Teschner et al. 2003's three large primes).
std::uint32_t cellHash(std::int64_t x, std::int64_t y, std::int64_t z) {
  const std::uint64_t mixed = static_cast<std::uint64_t>(x * 73856093) ^ static_cast<std::uint64_t>(y * 19349663) ^
                              static_cast<std::uint64_t>(z * 83492791);
  return static_cast<std::uint32_t>(mixed ^ (mixed >> 32));
}

constexpr int kPointBits = 32;

bool boxesOverlap(const Eigen::Matrix3Xd& lo, const Eigen::Matrix3Xd& hi, int i, int j) {
  return (lo.col(i).array() <= hi.col(j).array()).all() && (lo.col(j).array() <= hi.col(i).array()).all();
}

}  // namespace

void SweptPairFinder::find(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m,
                           const std::function<bool(int, int)>& keep, std::vector<std::pair<int, int>>* pairs) {
  pairs->clear();
  const int count = static_cast<int>(start_m.cols());
  if (count < 2 || !(reach_m > 0.0)) return;
  box_min_m_ = start_m.cwiseMin(end_m).array() - 0.5 * reach_m;
  box_max_m_ = start_m.cwiseMax(end_m).array() + 0.5 * reach_m;
  // Cells as wide as the reach, unless a fast point's box would span more than kMaxCellsPerAxis of them.
  const double widest_m = (box_max_m_ - box_min_m_).maxCoeff();
  const double cell_m = std::max(reach_m, widest_m / kMaxCellsPerAxis);
  entry_bucket_.clear();
  entry_point_.clear();
  for (int i = 0; i < count; ++i) {
    const Eigen::Array3d lo = (box_min_m_.col(i).array() / cell_m).floor();
    const Eigen::Array3d hi = (box_max_m_.col(i).array() / cell_m).floor();
    for (auto x = static_cast<std::int64_t>(lo.x()); x <= static_cast<std::int64_t>(hi.x()); ++x) {
      for (auto y = static_cast<std::int64_t>(lo.y()); y <= static_cast<std::int64_t>(hi.y()); ++y) {
        for (auto z = static_cast<std::int64_t>(lo.z()); z <= static_cast<std::int64_t>(hi.z()); ++z) {
          entry_bucket_.push_back(cellHash(x, y, z));
          entry_point_.push_back(i);
        }
      }
    }
  }
  // About two buckets per entry: few unrelated cells share one.
  const std::uint32_t buckets = static_cast<std::uint32_t>(2 * entry_point_.size() + 1);
  bucket_start_.assign(buckets + 1, 0);
  for (std::uint32_t& bucket : entry_bucket_) {
    bucket %= buckets;
    ++bucket_start_[bucket + 1];
  }
  for (std::uint32_t b = 0; b < buckets; ++b) bucket_start_[b + 1] += bucket_start_[b];
  sorted_points_.resize(entry_point_.size());
  std::vector<int>& next = bucket_start_;  // filled front to back, then shifted back below
  for (std::size_t e = 0; e < entry_point_.size(); ++e) sorted_points_[next[entry_bucket_[e]]++] = entry_point_[e];
  for (std::uint32_t b = buckets; b > 0; --b) next[b] = next[b - 1];
  next[0] = 0;
  found_.clear();
  for (std::uint32_t b = 0; b < buckets; ++b) {
    for (int a = bucket_start_[b]; a < bucket_start_[b + 1]; ++a) {
      for (int c = a + 1; c < bucket_start_[b + 1]; ++c) {
        const int i = std::min(sorted_points_[a], sorted_points_[c]);
        const int j = std::max(sorted_points_[a], sorted_points_[c]);
        if (i == j || !boxesOverlap(box_min_m_, box_max_m_, i, j) || !keep(i, j)) continue;
        found_.push_back(static_cast<std::uint64_t>(i) << kPointBits | static_cast<std::uint64_t>(j));
      }
    }
  }
  // A pair that shares several cells is found once per cell.
  std::sort(found_.begin(), found_.end());
  found_.erase(std::unique(found_.begin(), found_.end()), found_.end());
  pairs->reserve(found_.size());
  constexpr std::uint64_t kLowMask = (std::uint64_t{1} << kPointBits) - 1;
  for (const std::uint64_t packed : found_) {
    pairs->emplace_back(static_cast<int>(packed >> kPointBits), static_cast<int>(packed & kLowMask));
  }
}

}  // namespace cloth_sim::core
