// The regular grid as a stencil: every spring of one family joins particle (r, c) to (r + dr, c + dc),
// with one rest length for the whole family. The kernels below are stateless functions over flat
// structure-of-arrays fields (one contiguous array per coordinate), so their inner loops run over
// consecutive columns without an index table, a branch or a call per spring, and the compiler
// vectorises them. They work on a band of rows [row_begin, row_end) so that threads can share a grid.
//
// Each kernel writes one value per spring into a buffer slot indexed by the spring's first particle,
// shifted by the family's index offset (dr * cols + dc); a slot with no spring gets zero. A gather pass
// then gives particle i the spring that starts at i (slot offset + i) minus the one that ends at i
// (slot i), with no scatter and so no write shared between threads.
#pragma once

#include <array>
#include <cstddef>

namespace cloth_sim::core {

/// Read-only view of a 3-vector per particle as three arrays (x, y, z), N each.
struct ConstField {
  const double* x;
  const double* y;
  const double* z;
};

/// Writable view of the same.
struct Field {
  double* x;
  double* y;
  double* z;
  operator ConstField() const { return {x, y, z}; }
};

/// One spring family on a rows x cols grid: (r, c) -> (r + dr, c + dc), dr >= 0, and dc > 0 when dr = 0.
struct StencilFamily {
  int dr = 0;
  int dc = 1;
  double rest_length_m = 0.0;
  double stiffness_N_per_m = 0.0;
  double damping_N_s_per_m = 0.0;

  /// Index distance from a spring's first particle to its second; always > 0.
  int offset(int cols) const { return dr * cols + dc; }
};

/// The six families of the paper's model, in order: right, down, diagonal, anti-diagonal (structural
/// pair, shear pair), two right, two down (bend pair).
struct StencilFamilyLayout {
  int dr, dc;
  int kind;  ///< SpringKind as int
};
constexpr std::array<StencilFamilyLayout, 6> kStencilFamilies{{
    {0, 1, 0}, {1, 0, 0}, {1, 1, 1}, {1, -1, 1}, {0, 2, 2}, {2, 0, 2}}};

/// Below this a spring has no usable direction, m; it then exerts no force (as the edge-list kernel).
constexpr double kStencilDegenerateLength_m = 1e-6;

/// Per-spring force on the first particle, N: (Ks (l - L) + Kd (dv . u)) u with d = x_j - x_i, u = d/l.
/// Writes slots [offset + row_begin * cols, offset + row_end * cols) of `spring_force`, and the first
/// `offset` slots (zero) when row_begin is 0.
void stencilSpringForces(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                         ConstField velocities_m_per_s, Field spring_force_N, int row_begin, int row_end);

/// Linearisation of one family at the given positions, per spring slot (as above, but unshifted: slot
/// = first particle): 1 / l, and Ks * max(0, 1 - L / l), the part of the stiffness along the directions
/// across the spring. That part is dropped for a compressed spring (l < L), where it would make the
/// stiffness matrix indefinite (Baraff and Witkin's definiteness fix).
void stencilLinearize(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                      double* inverse_length_per_m, double* transverse_stiffness_N_per_m, int row_begin,
                      int row_end);

/// Per-spring differential force on the first particle, N, for position change dx and velocity change
/// dv: scale_x (a Ddx + (Ks - a) u (u . Ddx)) + scale_v Kd u (u . Ddv), with a the transverse stiffness,
/// Ddx = dx_j - dx_i, u from the linearised positions. Written like stencilSpringForces.
void stencilSpringDifferential(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                               const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                               ConstField dx, double scale_x, ConstField dv, double scale_v, Field spring_force_N,
                               int row_begin, int row_end);

/// Per-spring 3x3 block scale_x (a I + (Ks - a) u u^T) + scale_v Kd u u^T, its six entries (xx, yy, zz,
/// xy, xz, yz) into six arrays, shifted as in stencilSpringForces. Both ends of a spring get the same
/// block on their diagonal.
void stencilSpringBlocks(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                         const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                         double scale_x, double scale_v, const std::array<double*, 6>& blocks, int row_begin,
                         int row_end);

/// Gather for particles [begin, end): out_i += sign_start * slot[offset + i] + sign_end * slot[i], for
/// each of `arrays` arrays (forces: +1, -1; diagonal blocks: +1, +1).
void stencilGather(int offset, const double* const* slots, double* const* out, int arrays, double sign_end,
                   std::ptrdiff_t begin, std::ptrdiff_t end);

}  // namespace cloth_sim::core
