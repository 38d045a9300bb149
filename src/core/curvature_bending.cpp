#include "cloth_sim/core/curvature_bending.h"

#include <array>
#include <cmath>
#include <vector>

namespace cloth_sim::core {

Eigen::VectorXd keptArea(int rows, int cols, double du_m, double dv_m, const std::vector<std::uint8_t>& active) {
  Eigen::VectorXd area = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(rows) * cols);
  const double third_m2 = du_m * dv_m / 6.0;  // a third of a triangle (half a cell)
  const auto in = [&active](int p) { return active.empty() || active[static_cast<std::size_t>(p)] != 0; };
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c + 1 < cols; ++c) {
      const int p = r * cols + c;
      // The grid's two triangles of this cell (grid.cpp): (p, right, diagonal) and (p, diagonal, below).
      const int right = p + 1, below = p + cols, diagonal = p + cols + 1;
      for (const std::array<int, 3>& t : {std::array<int, 3>{p, right, diagonal}, std::array<int, 3>{p, diagonal, below}}) {
        if (!in(t[0]) || !in(t[1]) || !in(t[2])) continue;
        for (const int corner : t) area[corner] += third_m2;
      }
    }
  }
  return area;
}

void CurvatureBending::build(int rows, int cols, double du_m, double dv_m, double rigidity_N_m, double damping_s,
                             const std::vector<std::uint8_t>& active) {
  cols_ = cols;
  damping_s_ = damping_s;
  const int count = rows * cols;
  hessian_.resize(count, count);
  if (rigidity_N_m <= 0.0) return;
  // Per particle: a second difference each way (3 x 3 entries each) and a twist per cell (4 x 4).
  constexpr int kEntriesPerParticle = 2 * 9 + 16;
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<std::size_t>(count) * kEntriesPerParticle);
  const double cell_area_m2 = du_m * dv_m;
  // Adds scale (sum_a w_a x_a)^2 to the energy's quadratic form, i.e. scale w w^T to Q.
  const auto addSquare = [&entries](const int* index, const double* weight, int n, double scale) {
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) entries.emplace_back(index[a], index[b], scale * weight[a] * weight[b]);
    }
  };
  // Inside an outline a difference counts only where all its particles are, with each particle's area
  // from the triangles it keeps (a third of each); the whole rectangle keeps the exact shares.
  const auto in = [&active](int p) { return active.empty() || active[static_cast<std::size_t>(p)] != 0; };
  const Eigen::VectorXd outline_area = active.empty() ? Eigen::VectorXd() : keptArea(rows, cols, du_m, dv_m, active);
  const double uu = 1.0 / (du_m * du_m);
  const double vv = 1.0 / (dv_m * dv_m);
  for (int r = 0; r < rows; ++r) {
    const double row_share = (r == 0 || r == rows - 1) ? 0.5 : 1.0;
    for (int c = 0; c < cols; ++c) {
      const double col_share = (c == 0 || c == cols - 1) ? 0.5 : 1.0;
      const int p = r * cols + c;
      const double area_m2 = active.empty() ? cell_area_m2 * row_share * col_share : outline_area[p];
      if (c > 0 && c < cols - 1 && in(p - 1) && in(p) && in(p + 1)) {  // x_uu at p
        const int index[3] = {p - 1, p, p + 1};
        const double weight[3] = {uu, -2.0 * uu, uu};
        addSquare(index, weight, 3, rigidity_N_m * area_m2);
      }
      if (r > 0 && r < rows - 1 && in(p - cols) && in(p) && in(p + cols)) {  // x_vv at p
        const int index[3] = {p - cols, p, p + cols};
        const double weight[3] = {vv, -2.0 * vv, vv};
        addSquare(index, weight, 3, rigidity_N_m * area_m2);
      }
      // x_uv over the cell whose top-left corner is p, counted twice.
      if (r < rows - 1 && c < cols - 1 && in(p) && in(p + 1) && in(p + cols) && in(p + cols + 1)) {
        const double uv = 1.0 / cell_area_m2;
        const int index[4] = {p, p + 1, p + cols, p + cols + 1};
        const double weight[4] = {uv, -uv, -uv, uv};
        addSquare(index, weight, 4, 2.0 * rigidity_N_m * cell_area_m2);
      }
    }
  }
  hessian_.setFromTriplets(entries.begin(), entries.end());
}

void CurvatureBending::addForces(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                                 Eigen::Matrix3Xd& forces_N) const {
  addDifferential(positions_m, velocities_m_per_s, 1.0, 1.0, forces_N);
}

void CurvatureBending::addDifferential(const Eigen::Matrix3Xd& dx, const Eigen::Matrix3Xd& dv, double scale_x,
                                       double scale_v, Eigen::Matrix3Xd& out) const {
  if (empty()) return;
  // Q is symmetric, so X Q (3 x N times N x N) is (Q X^T)^T: one pass over Q's rows per call.
  const double damping = scale_v * damping_s_;
  if (damping != 0.0) {
    out.noalias() -= (scale_x * dx + damping * dv) * hessian_;
  } else {
    out.noalias() -= (scale_x * dx) * hessian_;
  }
}

double CurvatureBending::energy_J(const Eigen::Matrix3Xd& positions_m) const {
  if (empty()) return 0.0;
  const Eigen::Matrix3Xd qx = positions_m * hessian_;
  return 0.5 * positions_m.cwiseProduct(qx).sum();
}

Eigen::VectorXd CurvatureBending::rowAbsSums() const {
  Eigen::VectorXd sums = Eigen::VectorXd::Zero(hessian_.rows());
  for (int row = 0; row < hessian_.outerSize(); ++row) {
    for (Hessian::InnerIterator it(hessian_, row); it; ++it) sums[row] += std::abs(it.value());
  }
  return sums;
}

}  // namespace cloth_sim::core
