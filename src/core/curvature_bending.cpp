#include "cloth_sim/core/curvature_bending.h"

#include <cmath>
#include <vector>

namespace cloth_sim::core {

void CurvatureBending::build(int rows, int cols, double du_m, double dv_m, double rigidity_N_m, double damping_s) {
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
  const double uu = 1.0 / (du_m * du_m);
  const double vv = 1.0 / (dv_m * dv_m);
  for (int r = 0; r < rows; ++r) {
    const double row_share = (r == 0 || r == rows - 1) ? 0.5 : 1.0;
    for (int c = 0; c < cols; ++c) {
      const double col_share = (c == 0 || c == cols - 1) ? 0.5 : 1.0;
      const double area_m2 = cell_area_m2 * row_share * col_share;
      const int p = r * cols + c;
      if (c > 0 && c < cols - 1) {  // x_uu at p
        const int index[3] = {p - 1, p, p + 1};
        const double weight[3] = {uu, -2.0 * uu, uu};
        addSquare(index, weight, 3, rigidity_N_m * area_m2);
      }
      if (r > 0 && r < rows - 1) {  // x_vv at p
        const int index[3] = {p - cols, p, p + cols};
        const double weight[3] = {vv, -2.0 * vv, vv};
        addSquare(index, weight, 3, rigidity_N_m * area_m2);
      }
      if (r < rows - 1 && c < cols - 1) {  // x_uv over the cell whose top-left corner is p, counted twice
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
