// Broad phase for moving points (self-collision, issue 15): which pairs of particles may come within a
// distance of each other during one substep, found by a spatial hash over their swept boxes, rebuilt
// every call. The pairs come out in one deterministic order (i < j, sorted), whatever the hash collides.
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace cloth_sim::core {

/// Finds the pairs (i, j), i < j, whose swept boxes (the box around a point's start and end, grown by
/// `reach_m` / 2 on every side) overlap, i.e. every pair that can come within reach_m of each other on
/// straight paths from start to end, and that `keep` accepts. Each point goes into every cell of a
/// uniform grid its box touches (cells are hashed into a table of about twice the entries, as in
/// Teschner et al. 2003 and Mueller's hashed particle self-collision); the pairs of each cell are tested
/// box against box. Reuses its scratch memory from call to call.
class SweptPairFinder {
 public:
  /// Most cells a box may span along one axis: a point that moves further in one substep makes the
  /// cells larger for that call (fewer, fuller cells) rather than the table huge.
  static constexpr int kMaxCellsPerAxis = 4;

  /// start_m, end_m: 3 x N, any common frame. *pairs is replaced.
  void find(const Eigen::Matrix3Xd& start_m, const Eigen::Matrix3Xd& end_m, double reach_m,
            const std::function<bool(int, int)>& keep, std::vector<std::pair<int, int>>* pairs);

 private:
  std::vector<std::uint32_t> entry_bucket_;  ///< per (point, cell) entry: its bucket
  std::vector<int> entry_point_;
  std::vector<int> bucket_start_;            ///< counting sort of the entries by bucket
  std::vector<int> sorted_points_;
  std::vector<std::uint64_t> found_;         ///< pairs packed i << 32 | j, before sorting
  Eigen::Matrix3Xd box_min_m_;
  Eigen::Matrix3Xd box_max_m_;
};

}  // namespace cloth_sim::core
