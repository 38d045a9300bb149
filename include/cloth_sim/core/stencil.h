// The regular grid as a stencil: every spring of one family joins particle (r, c) to (r + dr, c + dc),
// with one rest length for the whole family. The kernels below are stateless functions over flat
// structure-of-arrays fields (one contiguous array per coordinate), so their inner loops run over
// consecutive columns without an index table, a branch or a call per spring, and the compiler
// vectorises them. They work on a band of rows [row_begin, row_end) so that threads can share a grid.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

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
};

/// One spring family on a rows x cols grid: (r, c) -> (r + dr, c + dc), dr >= 0, and dc > 0 when dr = 0.
struct StencilFamily {
  int dr = 0;
  int dc = 1;
  double rest_length_m = 0.0;
  double stiffness_N_per_m = 0.0;
  double damping_N_s_per_m = 0.0;
  /// The most a compressed spring pushes back, N (SpringOptions::buckling_N_m3 / L^3; infinite: linear).
  double compression_cap_N = std::numeric_limits<double>::infinity();
  /// Per particle index, 1 where the spring starting there exists, 0 where an outline removed it (an end
  /// outside); null: every spring exists.
  const std::uint8_t* present = nullptr;

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

/// The kernels below add the contributions of every spring of the given families that has an end in the
/// particle rows [row_begin, row_end) to those rows of the output, and write nothing outside them: a spring
/// that crosses into the band from the two rows above it is computed by both bands, so threads that own
/// disjoint bands need no lock, no barrier and no shared buffer, and each value is summed in the same
/// order whatever the bands. Each row of springs is computed into `row_scratch` (3 x cols doubles; 6 x
/// cols for the blocks), which stays in the L1 cache, then added to both ends.

/// Spring forces, N: on particle i of spring (i, j), (max(Ks (l - L), -cap) + Kd (v_j - v_i) . u) u with
/// d = x_j - x_i, l = |d|, u = d / l, cap the family's compression_cap_N; the opposite on j.
void stencilAccumulateSpringForces(int rows, int cols, const StencilFamily* families, int family_count,
                                   ConstField positions_m, ConstField velocities_m_per_s, Field forces_N,
                                   double* row_scratch, int row_begin, int row_end);

/// Linearisation of one family at the given positions, per spring (indexed by its first particle, rows
/// [row_begin, row_end) of first particles): 1 / l, and Ks * max(0, 1 - L / l), the part of the stiffness
/// across the spring. That part is dropped for a compressed spring (l < L), where it would make the
/// stiffness matrix indefinite (Baraff and Witkin's definiteness fix). A spring compressed past its cap
/// (its force constant, so no stiffness along it either) gets kCappedSpring instead.
constexpr double kCappedSpring = -1.0;
void stencilLinearize(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                      double* inverse_length_per_m, double* transverse_stiffness_N_per_m, int row_begin,
                      int row_end);

/// Differential spring forces, N, for the same change w applied to positions (scaled by scale_x) and
/// velocities (scaled by scale_v): on particle i, scale_x (a Dw + (Ks - a) u (u . Dw)) + scale_v Kd u
/// (u . Dw) with a the transverse stiffness (a capped spring: scale_v Kd u (u . Dw) alone), Dw = w_j - w_i,
/// u from the linearised positions; the opposite on j. Added to df_N. Per-family linearisation arrays are
/// indexed as `families`. The backward Euler system product takes (h^2, h); dF/dx dx alone (1, 0); dF/dv
/// dv alone (0, 1).
void stencilAccumulateDifferential(int rows, int cols, const StencilFamily* families, int family_count,
                                   ConstField linearized_positions_m, const double* const* inverse_length_per_m,
                                   const double* const* transverse_stiffness_N_per_m, ConstField w, double scale_x,
                                   double scale_v, Field df_N, double* row_scratch, int row_begin, int row_end);

/// The springs' part of the 3x3 diagonal blocks: scale_x (a I + (Ks - a) u u^T) + scale_v Kd u u^T added
/// to both ends' blocks, six arrays (xx, yy, zz, xy, xz, yz).
void stencilAccumulateBlocks(int rows, int cols, const StencilFamily* families, int family_count,
                             ConstField linearized_positions_m, const double* const* inverse_length_per_m,
                             const double* const* transverse_stiffness_N_per_m, double scale_x, double scale_v,
                             double* const* blocks, double* row_scratch, int row_begin, int row_end);

/// Each spring's own block of one family, scale_x (a I + (Ks - a) u u^T) + scale_v Kd u u^T, written (not
/// added) to six arrays indexed by the spring's first particle, for first particles in rows
/// [row_begin, row_end); entries of particles that start no spring are left alone.
void stencilSpringBlocks(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                         const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                         double scale_x, double scale_v, double* const* blocks, int row_begin, int row_end);

}  // namespace cloth_sim::core
