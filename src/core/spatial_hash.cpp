#include "cloth_sim/core/spatial_hash.h"

#include <cmath>

namespace cloth_sim::core {

namespace {

/// The hash of an integer cell (Teschner et al. 2003's three large primes).
std::uint32_t cellHash(std::int64_t x, std::int64_t y, std::int64_t z) {
  const std::uint64_t mixed = static_cast<std::uint64_t>(x * 73856093) ^ static_cast<std::uint64_t>(y * 19349663) ^
                              static_cast<std::uint64_t>(z * 83492791);
  return static_cast<std::uint32_t>(mixed ^ (mixed >> 32));
}

}  // namespace

void SweptPairFinder::setBoxes(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m) {
  const double half_m = 0.5 * reach_m;
  box_min_m_ = start_m.cwiseMin(end_m).array() - half_m;
  box_max_m_ = start_m.cwiseMax(end_m).array() + half_m;
}

bool SweptPairFinder::hashBoxes(double reach_m) {
  const int count = static_cast<int>(box_min_m_.cols());
  bucket_start_.clear();
  if (count < 2 || !(reach_m > 0.0)) return false;
  // Cells as wide as the reach, unless a fast point's box would span more than kMaxCellsPerAxis of them.
  const double widest_m = (box_max_m_ - box_min_m_).maxCoeff();
  cell_m_ = std::max(reach_m, widest_m / kMaxCellsPerAxis);
  entry_bucket_.clear();
  entry_point_.clear();
  entry_cell_.clear();
  low_cells_.resize(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const Eigen::Array3d lo = (box_min_m_.col(i).array() / cell_m_).floor();
    const Eigen::Array3d hi = (box_max_m_.col(i).array() / cell_m_).floor();
    low_cells_[static_cast<std::size_t>(i)] = {static_cast<std::int64_t>(lo.x()), static_cast<std::int64_t>(lo.y()),
                                               static_cast<std::int64_t>(lo.z())};
    for (auto x = static_cast<std::int64_t>(lo.x()); x <= static_cast<std::int64_t>(hi.x()); ++x) {
      for (auto y = static_cast<std::int64_t>(lo.y()); y <= static_cast<std::int64_t>(hi.y()); ++y) {
        for (auto z = static_cast<std::int64_t>(lo.z()); z <= static_cast<std::int64_t>(hi.z()); ++z) {
          entry_bucket_.push_back(cellHash(x, y, z));
          entry_point_.push_back(i);
          entry_cell_.push_back({x, y, z});
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
  sorted_cells_.resize(entry_point_.size());
  std::vector<int>& next = bucket_start_;  // filled front to back, then shifted back below
  for (std::size_t e = 0; e < entry_point_.size(); ++e) {
    const int slot = next[entry_bucket_[e]]++;
    sorted_points_[slot] = entry_point_[e];
    sorted_cells_[slot] = entry_cell_[e];
  }
  for (std::uint32_t b = buckets; b > 0; --b) next[b] = next[b - 1];
  next[0] = 0;
  return true;
}

void SweptPairFinder::sortPairs(int count, std::vector<std::pair<int, int>>* pairs) {
  first_start_.assign(static_cast<std::size_t>(count) + 1, 0);
  for (const auto& pair : *pairs) ++first_start_[static_cast<std::size_t>(pair.first) + 1];
  for (std::size_t i = 0; i < static_cast<std::size_t>(count); ++i) first_start_[i + 1] += first_start_[i];
  sorted_pairs_.resize(pairs->size());
  for (const auto& pair : *pairs) {
    int& slot = first_start_[static_cast<std::size_t>(pair.first)];
    sorted_pairs_[static_cast<std::size_t>(slot++)] = pair;
  }
  // first_start_[i] is now where i's pairs end; each group's partners in order.
  auto begin = sorted_pairs_.begin();
  for (std::size_t i = 0; i < static_cast<std::size_t>(count); ++i) {
    const auto end = sorted_pairs_.begin() + first_start_[i];
    std::sort(begin, end);
    begin = end;
  }
  pairs->swap(sorted_pairs_);
}

}  // namespace cloth_sim::core
