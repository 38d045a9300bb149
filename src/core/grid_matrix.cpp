#include "cloth_sim/core/grid_matrix.h"

#include "parallel.h"

#include <algorithm>

namespace cloth_sim::core {

std::vector<GridOffset> GridBlockMatrix::fullStencil() {
  std::vector<GridOffset> offsets;
  for (int dr = -kMaxReach; dr <= kMaxReach; ++dr)
    for (int dc = -kMaxReach; dc <= kMaxReach; ++dc) offsets.push_back({dr, dc});
  return offsets;
}

void GridBlockMatrix::reset(int rows, int cols, const std::vector<GridOffset>& offsets) {
  rows_ = rows;
  cols_ = cols;
  offsets_ = offsets;
  diagonal_ = offsetIndex(0, 0);
  blocks_.assign(static_cast<std::size_t>(rows) * cols * offsets.size() * kBlockEntries, 0.0);
}

int GridBlockMatrix::offsetIndex(int dr, int dc) const {
  for (std::size_t o = 0; o < offsets_.size(); ++o) {
    if (offsets_[o].dr == dr && offsets_[o].dc == dc) return static_cast<int>(o);
  }
  return -1;
}

void GridBlockMatrix::multiplyRange(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y, Eigen::Index begin,
                                    Eigen::Index end) const {
  const int offsets = static_cast<int>(offsets_.size());
  // Index distance of each offset, for particles whose whole stencil is on the grid.
  constexpr int kMostOffsets = (2 * kMaxReach + 1) * (2 * kMaxReach + 1);
  std::ptrdiff_t step[kMostOffsets];
  const bool stepped = offsets <= kMostOffsets;
  for (int o = 0; stepped && o < offsets; ++o) step[o] = static_cast<std::ptrdiff_t>(offsets_[o].dr) * cols_ + offsets_[o].dc;
  const double* xs = x.data();
  for (Eigen::Index p = begin; p < end; ++p) {
    const int r = static_cast<int>(p / cols_);
    const int c = static_cast<int>(p % cols_);
    double sum[3] = {0.0, 0.0, 0.0};
    const double* b = block(static_cast<int>(p), 0);
    const bool inside = stepped && r >= kMaxReach && r < rows_ - kMaxReach && c >= kMaxReach && c < cols_ - kMaxReach;
    if (inside) {
      for (int o = 0; o < offsets; ++o, b += kBlockEntries) addSymmetricBlockProduct(b, 1.0, xs + 3 * (p + step[o]), sum);
    } else {
      for (int o = 0; o < offsets; ++o, b += kBlockEntries) {
        const int qr = r + offsets_[o].dr;
        const int qc = c + offsets_[o].dc;
        if (qr < 0 || qr >= rows_ || qc < 0 || qc >= cols_) continue;
        addSymmetricBlockProduct(b, 1.0, x.col(static_cast<Eigen::Index>(qr) * cols_ + qc).data(), sum);
      }
    }
    y(0, p) = sum[0];
    y(1, p) = sum[1];
    y(2, p) = sum[2];
  }
}

void GridBlockMatrix::multiply(const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& y, int threads) const {
  y.resize(3, particles());
  forEachChunk(particles(), threads, [&](Eigen::Index begin, Eigen::Index end) { multiplyRange(x, y, begin, end); });
}

Eigen::MatrixXd GridBlockMatrix::dense() const {
  const int n = particles();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int p = 0; p < n; ++p) {
    const int r = p / cols_;
    const int c = p % cols_;
    for (std::size_t o = 0; o < offsets_.size(); ++o) {
      const int qr = r + offsets_[o].dr;
      const int qc = c + offsets_[o].dc;
      if (qr < 0 || qr >= rows_ || qc < 0 || qc >= cols_) continue;
      const int q = qr * cols_ + qc;
      const double* b = block(p, static_cast<int>(o));
      Eigen::Matrix3d m;
      m << b[0], b[3], b[4], b[3], b[1], b[5], b[4], b[5], b[2];
      a.block<3, 3>(3 * p, 3 * q) += m;
    }
  }
  return a;
}

}  // namespace cloth_sim::core
