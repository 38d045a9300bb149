// The curvature bending term (bend_model: curvature, issue 17): the paper's §2.1.3 energy E_b = M K s^2 / 2
// before it was simplified to springs, as a quadratic form on the grid in the spirit of Bergou et al.'s
// (2006) quadratic bending: the energy of a plate with Poisson ratio 0,
//     E = B/2 [ sum_i A_i (|x_uu|^2 + |x_vv|^2)_i + 2 sum_cells A |x_uv|^2 ],
// with B the bending rigidity (N m), x_uu and x_vv the second differences of the positions along the rows
// and columns at each particle that has both neighbours (A_i its share of the area) and x_uv the twist
// of each cell. For an isometric bend, |x_uu|^2 + |x_vv|^2 + 2 |x_uv|^2 is kappa_1^2 + kappa_2^2, so a bend
// of curvature k costs B k^2 / 2 per area from the first degree on, unlike the bend springs. (Bergou et
// al.'s cotangent Laplacian squared is |x_uu + x_vv|^2 on this grid: the plate with Poisson ratio 1, under
// which a free strip's saddle-shaped curl costs nothing: on the 25 mm cantilever strip it came out 2.4 %
// softer than the heavy elastica at 41 x 18 particles, and grew softer with every refinement, where this
// form converges at second order, 0.013 % off there; doc/PHYSICS.md.) The Hessian Q is constant (one
// matrix per grid, on the 13 offsets |dr| + |dc| <= 2, |dr|, |dc| <= 2 the implicit system already has)
// and every rigid motion of a flat grid has zero energy, because all three differences annihilate affine
// maps. Kelvin-Voigt damping adds beta Q v.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <cstdint>
#include <vector>

namespace cloth_sim::core {

/// Each particle's share of the area of the grid's triangles whose three corners are active (a third of
/// each), m^2: an outline's lumped areas (`active` empty: the whole rectangle's).
Eigen::VectorXd keptArea(int rows, int cols, double du_m, double dv_m, const std::vector<std::uint8_t>& active);

class CurvatureBending {
 public:
  using Hessian = Eigen::SparseMatrix<double, Eigen::RowMajor>;

  /// Builds Q for a rows x cols grid with spacing du_m along a row and dv_m along a column, rigidity
  /// rigidity_N_m and retardation time damping_s. Rigidity 0 leaves the term empty.
  /// `active` (empty: all): an outline's particles; differences reaching outside it are left out.
  void build(int rows, int cols, double du_m, double dv_m, double rigidity_N_m, double damping_s,
             const std::vector<std::uint8_t>& active = {});
  void clear() { hessian_.resize(0, 0); }
  bool empty() const { return hessian_.nonZeros() == 0; }

  /// Q (N x N): E = 1/2 sum over the three coordinates of x_c^T Q x_c; the force is -Q x per coordinate.
  const Hessian& hessian() const { return hessian_; }
  double damping_s() const { return damping_s_; }
  int cols() const { return cols_; }

  /// forces_N -= Q x + damping Q v (3 x N each, world frame).
  void addForces(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                 Eigen::Matrix3Xd& forces_N) const;
  /// out -= Q (scale_x dx + scale_v damping dv): the differential for a change dx, dv (scale 1, 1), or
  /// the implicit system's part with scale_x = h^2 and scale_v = h (then subtracted, so callers negate).
  void addDifferential(const Eigen::Matrix3Xd& dx, const Eigen::Matrix3Xd& dv, double scale_x, double scale_v,
                       Eigen::Matrix3Xd& out) const;
  /// The energy above, J.
  double energy_J(const Eigen::Matrix3Xd& positions_m) const;
  /// Per particle, sum_j |Q_ij| (N/m): the term's share of a Gershgorin bound on the stiffness.
  Eigen::VectorXd rowAbsSums() const;

 private:
  Hessian hessian_;
  double damping_s_ = 0.0;
  int cols_ = 0;
};

}  // namespace cloth_sim::core
