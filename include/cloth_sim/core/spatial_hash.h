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
/// straight paths from start to end, and that `keep(i, j)` accepts. Each point goes into the one cell of a
/// uniform grid that holds its box's low corner (cells are hashed, as in Teschner et al. 2003 and
/// Mueller's hashed particle self-collision); a point's partners have their low corners in the cells from
/// its own, less the widest box's span, up to the last cell its own box touches, and each pair is tested
/// once, from the cell of its first point. Reuses its scratch memory from call to call.
class SweptPairFinder {
 public:
  /// The widest box spans at most this many cell widths: cells as wide as the reach, unless a point moves
  /// so far in one substep that its box (its motion plus the reach) is wider than that. A cell's partners
  /// are looked for in about (2 kMaxSpan + 1)^3 cells around it (one more per axis where rounding puts a
  /// box's ends in cells further apart), so a fast point makes the cells larger for that call (fewer,
  /// fuller cells) rather than that many.
  static constexpr int kMaxSpan = 2;
  /// Hash table slots per point: at most half full, so probes are short and always end.
  static constexpr std::size_t kSlotsPerPoint = 2;

  /// start_m, end_m: 3 x N, finite, any common frame (cells are integer coordinates: |x| / reach must stay
  /// far below 2^62). *pairs is replaced. Keep: bool(int i, int j), i < j.
  template <typename Keep>
  void find(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m, const Keep& keep,
            std::vector<std::pair<int, int>>* pairs) {
    pairs->clear();
    setBoxes(start_m, end_m, reach_m);
    if (!hashBoxes(reach_m)) return;
    for (const Cell& home : cells_) {
      for (std::int64_t dx = -span_[0]; dx <= home.span[0]; ++dx) {
        for (std::int64_t dy = -span_[1]; dy <= home.span[1]; ++dy) {
          for (std::int64_t dz = -span_[2]; dz <= home.span[2]; ++dz) {
            const int other = cellAt({home.key[0] + dx, home.key[1] + dy, home.key[2] + dz});
            if (other >= 0) pairCells(home, cells_[static_cast<std::size_t>(other)], keep, pairs);
          }
        }
      }
    }
    sortPairs(static_cast<int>(start_m.cols()), pairs);
  }

  /// The swept boxes of the last setBoxes (or find): each point's start and end, grown by reach_m / 2.
  void setBoxes(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m);
  /// Whether the boxes of i and j overlap (find keeps the pairs that do and that `keep` accepts).
  bool boxesOverlap(int i, int j) const {
    return overlap(boxes_m_.col(i).data(), boxes_m_.col(j).data());
  }

 private:
  using CellKey = std::array<std::int64_t, 3>;
  struct Cell {
    CellKey key;     ///< integer cell coordinates
    CellKey span;    ///< per axis, the most cells past its own that one of its points' boxes reaches
    int begin = 0;   ///< its points in sorted_points_ (increasing)
    int end = 0;
  };

  /// Boxes as six numbers: the low corner, then the high one.
  using Boxes = Eigen::Matrix<double, 6, Eigen::Dynamic>;
  static bool overlap(const double* box_i, const double* box_j) {
    // & not &&: all six tests, no branch between them.
    return (box_i[0] <= box_j[3]) & (box_i[1] <= box_j[4]) & (box_i[2] <= box_j[5]) & (box_j[0] <= box_i[3]) &
           (box_j[1] <= box_i[4]) & (box_j[2] <= box_i[5]);
  }

  /// Tests every point of `home` against the points of `other` with a larger index.
  template <typename Keep>
  void pairCells(const Cell& home, const Cell& other, const Keep& keep, std::vector<std::pair<int, int>>* pairs) const {
    int first = other.begin;  // other's first point after i; both cells' points increase
    for (int a = home.begin; a < home.end; ++a) {
      const int i = sorted_points_[static_cast<std::size_t>(a)];
      while (first < other.end && sorted_points_[static_cast<std::size_t>(first)] <= i) ++first;
      const double* box_i = sorted_boxes_m_.col(a).data();
      for (int b = first; b < other.end; ++b) {
        // The boxes first: they lie in order in memory; keep, which turns away the grid's neighbours,
        // reads per-point tables.
        if (!overlap(box_i, sorted_boxes_m_.col(b).data())) continue;
        const int j = sorted_points_[static_cast<std::size_t>(b)];
        if (keep(i, j)) pairs->emplace_back(i, j);
      }
    }
  }

  /// Sorts *pairs (each (i, j) once, 0 <= i < j < count) as std::sort would, in two counting passes
  /// (a radix sort with the particle index as digit): by j, then, keeping that order, by i. A comparison
  /// sort of the whole list cost a third of the broad phase, and sorting each i's partners after counting
  /// out by i still 11 % of a frame where the 64 x 64 fold lands (perf).
  void sortPairs(int count, std::vector<std::pair<int, int>>* pairs);
  /// One stable counting pass of sortPairs: `from` into `to` in the order of key(pair), 0 <= key < count.
  template <typename Key>
  void countOut(int count, const std::vector<std::pair<int, int>>& from, Key key, std::vector<std::pair<int, int>>* to);
  /// Puts every point into the cell of its box's low corner; false when there is nothing to pair.
  bool hashBoxes(double reach_m);
  /// The index in cells_ of the cell with this key, or -1 if no point's low corner is in it.
  int cellAt(const CellKey& key) const;
  static std::uint64_t hashKey(const CellKey& key);
  /// std::array's == compiles to a call of memcmp, which was 1.5 % of the 64 x 64 fold (perf).
  static bool sameKey(const CellKey& a, const CellKey& b) { return a[0] == b[0] && a[1] == b[1] && a[2] == b[2]; }

  double cell_m_ = 1.0;
  CellKey span_{};                   ///< per axis, the most cells past its own that any box reaches
  std::vector<Cell> cells_;          ///< the occupied cells, in the order of their first point
  std::vector<int> table_;           ///< open addressing: cells_ index + 1, 0 where empty
  std::vector<int> cell_of_;         ///< per point: its cell in cells_
  std::vector<int> sorted_points_;   ///< the points, cell by cell, each cell's in increasing order
  Boxes sorted_boxes_m_;             ///< their boxes, in the same order
  std::vector<int> key_start_;  ///< countOut: where each key's pairs go next
  std::vector<std::pair<int, int>> sorted_pairs_;
  Boxes boxes_m_;  ///< per point, its box; read in pairs of points, so its two corners lie together
};

}  // namespace cloth_sim::core
