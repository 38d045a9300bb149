// A sparse symmetric matrix on a rows x cols particle grid, stored as a block stencil: particle (r, c)
// couples with (r + dr, c + dc) for a fixed list of offsets through a symmetric 3x3 block. The backward
// Euler system of the cloth has 13 such offsets (itself, and the six spring families both ways); the
// Galerkin coarse operators of multigrid have the 25 offsets |dr|, |dc| <= 2. Plain arrays: the products
// are loops over particles and offsets, with no index table per entry.
#pragma once

#include <Eigen/Core>

#include <vector>

namespace cloth_sim::core {

struct GridOffset {
  int dr = 0;
  int dc = 0;
};

class GridBlockMatrix {
 public:
  /// Entries per block: a symmetric 3x3 block as xx, yy, zz, xy, xz, yz (the order of
  /// Dynamics::systemDiagonalBlocks).
  static constexpr int kBlockEntries = 6;
  /// Farthest coupling along a row or column, particles: the bend springs reach two away, and the
  /// Galerkin product of bilinear transfers keeps that reach on every coarser grid.
  static constexpr int kMaxReach = 2;

  /// The 25 offsets |dr|, |dc| <= kMaxReach, row-major.
  static std::vector<GridOffset> fullStencil();

  /// Sizes the matrix for the grid and the offsets (which must hold {0, 0}); every block zero.
  void reset(int rows, int cols, const std::vector<GridOffset>& offsets);

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  int particles() const { return rows_ * cols_; }
  const std::vector<GridOffset>& offsets() const { return offsets_; }
  /// Index of {dr, dc} in offsets(), or -1.
  int offsetIndex(int dr, int dc) const;
  int diagonalIndex() const { return diagonal_; }

  /// The block coupling particle p with particle p + offsets()[o] (zero where that is off the grid).
  double* block(int particle, int offset) {
    return blocks_.data() + (static_cast<std::ptrdiff_t>(particle) * offsets_.size() + offset) * kBlockEntries;
  }
  const double* block(int particle, int offset) const {
    return blocks_.data() + (static_cast<std::ptrdiff_t>(particle) * offsets_.size() + offset) * kBlockEntries;
  }

  /// y = A x (3 x N each), particles split into chunks on `threads` threads; the same bits for any count.
  void multiply(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y, int threads) const;
  /// y_p = (A x)_p for the particles [begin, end).
  void multiplyRange(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y, Eigen::Index begin, Eigen::Index end) const;
  /// The matrix as a dense 3N x 3N one (tests, and the coarsest level's direct solve).
  Eigen::MatrixXd dense() const;

 private:
  int rows_ = 0;
  int cols_ = 0;
  int diagonal_ = -1;
  std::vector<GridOffset> offsets_;
  std::vector<double> blocks_;  ///< [particle][offset][kBlockEntries]
};

/// out += scale * B v for a symmetric block B (kBlockEntries) and 3-vectors v, out.
inline void addSymmetricBlockProduct(const double* b, double scale, const double* v, double* out) {
  out[0] += scale * (b[0] * v[0] + b[3] * v[1] + b[4] * v[2]);
  out[1] += scale * (b[3] * v[0] + b[1] * v[1] + b[5] * v[2]);
  out[2] += scale * (b[4] * v[0] + b[5] * v[1] + b[2] * v[2]);
}

}  // namespace cloth_sim::core
