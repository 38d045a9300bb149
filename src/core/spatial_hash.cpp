#include "cloth_sim/core/spatial_hash.h"

#include <cmath>

namespace cloth_sim::core {

void SweptPairFinder::setBoxes(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m) {
  const double half_m = 0.5 * reach_m;
  boxes_m_.resize(6, start_m.cols());
  boxes_m_.topRows<3>() = start_m.cwiseMin(end_m).array() - half_m;
  boxes_m_.bottomRows<3>() = start_m.cwiseMax(end_m).array() + half_m;
}

std::uint64_t SweptPairFinder::hashKey(const CellKey& key) {
  // Teschner et al. 2003's three large primes, then mixed so that the table's low bits depend on all of them.
  std::uint64_t mixed = static_cast<std::uint64_t>(key[0]) * 73856093u ^
                        static_cast<std::uint64_t>(key[1]) * 19349663u ^ static_cast<std::uint64_t>(key[2]) * 83492791u;
  // The table's index is the low bits: fold the high half into them, spread every bit over the high
  // ones by a multiplication (2^64 / the golden ratio, Fibonacci hashing), and fold those back down.
  mixed ^= mixed >> 32;
  mixed *= 0x9E3779B97F4A7C15u;
  return mixed ^ (mixed >> 29);
}

int SweptPairFinder::cellAt(const CellKey& key) const {
  const std::size_t mask = table_.size() - 1;
  for (std::size_t slot = hashKey(key) & mask; table_[slot] != 0; slot = (slot + 1) & mask) {
    const int cell = table_[slot] - 1;
    if (sameKey(cells_[static_cast<std::size_t>(cell)].key, key)) return cell;
  }
  return -1;
}

bool SweptPairFinder::hashBoxes(double reach_m) {
  const int count = static_cast<int>(boxes_m_.cols());
  cells_.clear();
  if (count < 2 || !(reach_m > 0.0)) return false;
  // Cells as wide as the reach, unless a fast point's box would span more than kMaxSpan of them.
  const double widest_m = (boxes_m_.bottomRows<3>() - boxes_m_.topRows<3>()).maxCoeff();
  cell_m_ = std::max(reach_m, widest_m / kMaxSpan);
  std::size_t capacity = 1;
  while (capacity < kSlotsPerPoint * static_cast<std::size_t>(count)) capacity <<= 1;
  table_.assign(capacity, 0);
  const std::size_t mask = capacity - 1;
  span_ = {0, 0, 0};
  cell_of_.resize(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const Eigen::Array3d lo = (boxes_m_.col(i).head<3>().array() / cell_m_).floor();
    const Eigen::Array3d hi = (boxes_m_.col(i).tail<3>().array() / cell_m_).floor();
    const CellKey key{static_cast<std::int64_t>(lo.x()), static_cast<std::int64_t>(lo.y()),
                      static_cast<std::int64_t>(lo.z())};
    CellKey span{};
    for (int axis = 0; axis < 3; ++axis) {
      span[axis] = static_cast<std::int64_t>(hi[axis]) - key[axis];
      span_[axis] = std::max(span_[axis], span[axis]);
    }
    std::size_t slot = hashKey(key) & mask;
    while (table_[slot] != 0 && !sameKey(cells_[static_cast<std::size_t>(table_[slot] - 1)].key, key)) {
      slot = (slot + 1) & mask;
    }
    if (table_[slot] == 0) {
      cells_.push_back(Cell{key, span, 0, 0});
      table_[slot] = static_cast<int>(cells_.size());
    }
    Cell& cell = cells_[static_cast<std::size_t>(table_[slot] - 1)];
    for (int axis = 0; axis < 3; ++axis) cell.span[axis] = std::max(cell.span[axis], span[axis]);
    ++cell.end;  // counts its points until the offsets below
    cell_of_[static_cast<std::size_t>(i)] = table_[slot] - 1;
  }
  int offset = 0;
  for (Cell& cell : cells_) {
    cell.begin = offset;
    offset += cell.end;
    cell.end = cell.begin;  // filled below
  }
  sorted_points_.resize(static_cast<std::size_t>(count));
  sorted_boxes_m_.resize(6, count);
  for (int i = 0; i < count; ++i) {
    const int slot = cells_[static_cast<std::size_t>(cell_of_[static_cast<std::size_t>(i)])].end++;
    sorted_points_[static_cast<std::size_t>(slot)] = i;
    sorted_boxes_m_.col(slot) = boxes_m_.col(i);
  }
  return true;
}

template <typename Key>
void SweptPairFinder::countOut(int count, const std::vector<std::pair<int, int>>& from, Key key,
                               std::vector<std::pair<int, int>>* to) {
  key_start_.assign(static_cast<std::size_t>(count) + 1, 0);
  for (const auto& pair : from) ++key_start_[static_cast<std::size_t>(key(pair)) + 1];
  for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k) key_start_[k + 1] += key_start_[k];
  to->resize(from.size());
  for (const auto& pair : from) (*to)[static_cast<std::size_t>(key_start_[static_cast<std::size_t>(key(pair))]++)] = pair;
}

void SweptPairFinder::sortPairs(int count, std::vector<std::pair<int, int>>* pairs) {
  countOut(count, *pairs, [](const std::pair<int, int>& pair) { return pair.second; }, &sorted_pairs_);
  countOut(count, sorted_pairs_, [](const std::pair<int, int>& pair) { return pair.first; }, pairs);
}

}  // namespace cloth_sim::core
