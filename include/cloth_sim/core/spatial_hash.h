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
          // Cheapest first: most pairs meet again in a cell that is not their first shared one (near points
          // share most of their cells), and keep turns most of the rest away (neighbours on the cloth's
          // grid); the boxes' overlap, which reads both boxes, last.
          if (i == j || !isFirstSharedCell(i, j, sorted_cells_[a]) || !keep(i, j) || !boxesOverlap(i, j)) continue;
          pairs->emplace_back(i, j);
        }
      }
    }
    sortPairs(static_cast<int>(start_m.cols()), pairs);
  }

  /// The swept boxes of the last setBoxes (or find): each point's start and end, grown by reach_m / 2.
  void setBoxes(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m);
  /// Whether the boxes of i and j overlap (find keeps the pairs that do and that `keep` accepts).
  bool boxesOverlap(int i, int j) const {
    const double* min_i = box_min_m_.col(i).data();
    const double* max_i = box_max_m_.col(i).data();
    const double* min_j = box_min_m_.col(j).data();
    const double* max_j = box_max_m_.col(j).data();
    // & not &&: all six tests, no branch between them.
    return (min_i[0] <= max_j[0]) & (min_i[1] <= max_j[1]) & (min_i[2] <= max_j[2]) & (min_j[0] <= max_i[0]) &
           (min_j[1] <= max_i[1]) & (min_j[2] <= max_i[2]);
  }

 private:
  using Cell = std::array<std::int64_t, 3>;
  static bool sameCell(const Cell& a, const Cell& b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }
  /// Sorts *pairs (each (i, j) once, 0 <= i < j < count) as std::sort would: counted out by i, then each
  /// i's few partners sorted; a comparison sort of the whole list cost a third of the broad phase.
  void sortPairs(int count, std::vector<std::pair<int, int>>* pairs);
  /// Fills the table from the boxes; false when there is nothing to pair.
  bool hashBoxes(double reach_m);
  /// Whether `cell`, which the boxes of i and j both touch, is the first cell they share (the cell of the
  /// larger of their low corners, per axis; floor is monotonic): each overlapping pair is kept in exactly
  /// one cell.
  bool isFirstSharedCell(int i, int j, const Cell& cell) const {
    const Cell& low_i = low_cells_[static_cast<std::size_t>(i)];
    const Cell& low_j = low_cells_[static_cast<std::size_t>(j)];
    return (std::max(low_i[0], low_j[0]) == cell[0]) & (std::max(low_i[1], low_j[1]) == cell[1]) &
           (std::max(low_i[2], low_j[2]) == cell[2]);
  }

  double cell_m_ = 1.0;
  std::vector<std::uint32_t> entry_bucket_;  ///< per (point, cell) entry: its bucket
  std::vector<int> entry_point_;
  std::vector<Cell> entry_cell_;
  std::vector<int> bucket_start_;            ///< counting sort of the entries by bucket
  std::vector<int> sorted_points_;
  std::vector<Cell> sorted_cells_;
  std::vector<Cell> low_cells_;  ///< per point: the cell of its box's low corner
  std::vector<int> first_start_;  ///< sortPairs: where each i's pairs start
  std::vector<std::pair<int, int>> sorted_pairs_;
  Eigen::Matrix3Xd box_min_m_;
  Eigen::Matrix3Xd box_max_m_;
};

}  // namespace cloth_sim::core
