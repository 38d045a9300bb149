// Broad phase for moving points (self-collision, issue 15): which pairs of particles may come within a
// distance of each other during one substep, found by a spatial hash over their swept boxes, rebuilt
// every call. The pairs come out in one deterministic order (i < j, sorted), whatever the hash collides.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace cloth_sim::core {

/// Finds the pairs (i, j), i < j, whose swept boxes (the box around a point's start and end, grown by
/// `reach_m` / 2 on every side) overlap, i.e. every pair that can come within reach_m of each other on
/// straight paths from start to end, and that `keep(i, j)` accepts. Each point goes into every cell of a
/// uniform grid its box touches (cells are hashed into a table of about twice the entries, as in
/// Teschner et al. 2003 and Mueller's hashed particle self-collision); a pair is tested once, in the
/// first cell its two boxes share. Reuses its scratch memory from call to call.
class SweptPairFinder {
 public:
  /// Most cells a box may span along one axis: a point that moves further in one substep makes the
  /// cells larger for that call (fewer, fuller cells) rather than the table huge.
  static constexpr int kMaxCellsPerAxis = 4;

  /// start_m, end_m: 3 x N, any common frame. *pairs is replaced. Keep: bool(int i, int j), i < j.
  template <typename Keep>
  void find(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m, const Keep& keep,
            std::vector<std::pair<int, int>>* pairs) {
    pairs->clear();
    setBoxes(start_m, end_m, reach_m);
    if (!hashBoxes(reach_m)) return;
    for (std::size_t b = 0; b + 1 < bucket_start_.size(); ++b) {
      for (int a = bucket_start_[b]; a < bucket_start_[b + 1]; ++a) {
        for (int c = a + 1; c < bucket_start_[b + 1]; ++c) {
          if (!sameCell(sorted_cells_[a], sorted_cells_[c])) continue;  // another cell in the same bucket
          const int i = std::min(sorted_points_[a], sorted_points_[c]);
          const int j = std::max(sorted_points_[a], sorted_points_[c]);
          // keep first: it turns most pairs away (neighbours on the cloth's grid).
          if (i == j || !keep(i, j) || !firstSharedCell(i, j, sorted_cells_[a])) continue;
          pairs->emplace_back(i, j);
        }
      }
    }
    std::sort(pairs->begin(), pairs->end());
  }

  /// The swept boxes of the last setBoxes (or find): each point's start and end, grown by reach_m / 2.
  void setBoxes(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m);
  /// Whether the boxes of i and j overlap (what find pairs, before `keep`).
  bool boxesOverlap(int i, int j) const {
    return (box_min_m_.col(i).array() <= box_max_m_.col(j).array()).all() &&
           (box_min_m_.col(j).array() <= box_max_m_.col(i).array()).all();
  }

 private:
  using Cell = std::array<std::int64_t, 3>;
  static bool sameCell(const Cell& a, const Cell& b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }
  /// Fills the table from the boxes; false when there is nothing to pair.
  bool hashBoxes(double reach_m);
  /// Whether the boxes of i and j overlap and `cell` is the first cell they share (the cell of the larger
  /// of their low corners, per axis): each overlapping pair is tested in exactly one cell.
  bool firstSharedCell(int i, int j, const Cell& cell) const;

  double cell_m_ = 1.0;
  std::vector<std::uint32_t> entry_bucket_;  ///< per (point, cell) entry: its bucket
  std::vector<int> entry_point_;
  std::vector<Cell> entry_cell_;
  std::vector<int> bucket_start_;            ///< counting sort of the entries by bucket
  std::vector<int> sorted_points_;
  std::vector<Cell> sorted_cells_;
  std::vector<Cell> low_cells_;  ///< per point: the cell of its box's low corner
  Eigen::Matrix3Xd box_min_m_;
  Eigen::Matrix3Xd box_max_m_;
};

}  // namespace cloth_sim::core
