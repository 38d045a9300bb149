#include "cloth_sim/core/stencil.h"

#include "vector_clones.h"

#include <algorithm>
#include <cmath>

namespace cloth_sim::core {

namespace {

/// The columns of row r that start a spring of the family, [first, last); empty when the row has none.
struct ColumnRange {
  int first = 0;
  int last = 0;
};

ColumnRange springColumns(int rows, int cols, const StencilFamily& family, int row) {
  if (row + family.dr >= rows) return {};
  return {std::max(0, -family.dc), cols - std::max(0, family.dc)};
}

/// 1 / l, or 0 for a spring too short to have a direction (it then exerts nothing). A select, which the
/// compiler turns into a blend (with -fno-trapping-math), so the loops around it stay vectorised.
inline double inverseLength(double length_m) { return length_m > kStencilDegenerateLength_m ? 1.0 / length_m : 0.0; }

// The per-row loops take every array as a __restrict function parameter, shifted to the row's first
// spring: GCC 12 vectorises them in that form (and not with __restrict locals), once per SIMD width
// (vector_clones.h).
CLOTH_SIM_VECTOR_CLONES void springForceRow(int count, int offset, double ks, double kd, double rest, double cap,
                                            const double* __restrict px, const double* __restrict py,
                                            const double* __restrict pz, const double* __restrict vx,
                                            const double* __restrict vy, const double* __restrict vz,
                                            double* __restrict fx, double* __restrict fy, double* __restrict fz) {
  for (int i = 0; i < count; ++i) {
    const int j = i + offset;
    const double dx = px[j] - px[i];
    const double dy = py[j] - py[i];
    const double dz = pz[j] - pz[i];
    const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double inverse = inverseLength(length);
    const double separation_rate = ((vx[j] - vx[i]) * dx + (vy[j] - vy[i]) * dy + (vz[j] - vz[i]) * dz) * inverse;
    // The cap: at most the load at which the strip of fabric the spring stands for buckles (max with
    // -infinity, the linear spring, changes no bit).
    const double elastic = std::max(ks * (length - rest), -cap);
    const double magnitude = (elastic + kd * separation_rate) * inverse;
    fx[i] = magnitude * dx;
    fy[i] = magnitude * dy;
    fz[i] = magnitude * dz;
  }
}

CLOTH_SIM_VECTOR_CLONES void linearizeRow(int count, int offset, double ks, double rest, double cap,
                                          const double* __restrict px, const double* __restrict py,
                                          const double* __restrict pz, double* __restrict inverse_length,
                                          double* __restrict transverse) {
  for (int i = 0; i < count; ++i) {
    const int j = i + offset;
    const double dx = px[j] - px[i];
    const double dy = py[j] - py[i];
    const double dz = pz[j] - pz[i];
    const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double inverse = inverseLength(length);
    inverse_length[i] = inverse;
    const double across = 1.0 - rest * inverse;
    transverse[i] = ks * (length - rest) < -cap ? kCappedSpring : ks * (across > 0.0 ? across : 0.0);
  }
}

/// Differential spring forces of one row for the same change w in positions and velocities, scaled:
/// scale_x (a Dw + (Ks - a) u (u . Dw)) + kd_scaled u (u . Dw).
CLOTH_SIM_VECTOR_CLONES void differentialRow(int count, int offset, double ks, double kd_scaled, double scale_x,
                                                 const double* __restrict px, const double* __restrict py,
                                                 const double* __restrict pz, const double* __restrict inverse_length,
                                                 const double* __restrict transverse, const double* __restrict wx,
                                                 const double* __restrict wy, const double* __restrict wz,
                                                 double* __restrict fx, double* __restrict fy, double* __restrict fz) {
  for (int i = 0; i < count; ++i) {
    const int j = i + offset;
    const double ux = (px[j] - px[i]) * inverse_length[i];
    const double uy = (py[j] - py[i]) * inverse_length[i];
    const double uz = (pz[j] - pz[i]) * inverse_length[i];
    const double dwx = wx[j] - wx[i];
    const double dwy = wy[j] - wy[i];
    const double dwz = wz[j] - wz[i];
    // A capped spring has no stiffness: neither across (a = 0) nor along it (Ks - a = 0).
    const double a = transverse[i] > 0.0 ? transverse[i] : 0.0;
    const double stiffness_along = transverse[i] < 0.0 ? 0.0 : ks - a;
    const double along = (scale_x * stiffness_along + kd_scaled) * (ux * dwx + uy * dwy + uz * dwz);
    const double across = scale_x * a;
    fx[i] = across * dwx + along * ux;
    fy[i] = across * dwy + along * uy;
    fz[i] = across * dwz + along * uz;
  }
}

CLOTH_SIM_VECTOR_CLONES void blockRow(int count, int offset, double ks, double kd_scaled, double scale_x, const double* __restrict px,
              const double* __restrict py, const double* __restrict pz, const double* __restrict inverse_length,
              const double* __restrict transverse, double* __restrict bxx, double* __restrict byy,
              double* __restrict bzz, double* __restrict bxy, double* __restrict bxz, double* __restrict byz) {
  for (int i = 0; i < count; ++i) {
    const int j = i + offset;
    const double ux = (px[j] - px[i]) * inverse_length[i];
    const double uy = (py[j] - py[i]) * inverse_length[i];
    const double uz = (pz[j] - pz[i]) * inverse_length[i];
    const double a = transverse[i] > 0.0 ? transverse[i] : 0.0;
    const double stiffness_along = transverse[i] < 0.0 ? 0.0 : ks - a;
    const double across = scale_x * a;
    const double along = scale_x * stiffness_along + kd_scaled;
    bxx[i] = across + along * ux * ux;
    byy[i] = across + along * uy * uy;
    bzz[i] = across + along * uz * uz;
    bxy[i] = along * ux * uy;
    bxz[i] = along * ux * uz;
    byz[i] = along * uy * uz;
  }
}

}  // namespace

namespace {

/// target[i] += sign * value[i] for `count` entries. sign is 1 or -1, so every clone adds the same bits
/// (as a plain add would).
CLOTH_SIM_VECTOR_CLONES void addSignedRow(int count, double sign, const double* __restrict value,
                                          double* __restrict target) {
  for (int i = 0; i < count; ++i) target[i] += sign * value[i];
}

/// Adds row buffer `spring` (springs starting at row r, columns range.first..) to the first ends (if row r
/// is in the band) and `sign_second` times it to the second ends (if row r + dr is in the band).
void applyRow(int cols, int row, ColumnRange range, int offset, int row_begin, int row_end, int dr, int arrays,
              const double* const* spring, double* const* out, double sign_second) {
  const int count = range.last - range.first;
  const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(row) * cols + range.first;
  const bool first_in_band = row >= row_begin;
  const bool second_in_band = row + dr >= row_begin && row + dr < row_end;
  for (int a = 0; a < arrays; ++a) {
    if (first_in_band) addSignedRow(count, 1.0, spring[a], out[a] + first);
    if (second_in_band) addSignedRow(count, sign_second, spring[a], out[a] + first + offset);
  }
}

/// Zeroes the values of the springs an outline removed (family.present is 0 at their first particle),
/// for the `count` springs starting at particle index `first`; nothing without an outline.
void clearMissingSprings(const StencilFamily& family, int count, std::ptrdiff_t first, int arrays, double* const* values) {
  if (family.present == nullptr) return;
  const std::uint8_t* present = family.present + first;
  for (int i = 0; i < count; ++i) {
    if (present[i] != 0) continue;
    for (int a = 0; a < arrays; ++a) values[a][i] = 0.0;
  }
}

/// Most row-scratch arrays a kernel uses: the six entries of a symmetric 3x3 block.
constexpr int kMaxRowArrays = 6;

/// Rows whose springs may end in the band: two more above it (the bend springs reach two rows down).
int firstSourceRow(int row_begin) { return std::max(0, row_begin - 2); }

}  // namespace

namespace {

/// The rows of springs that can end in the band [row_begin, row_end), family by family: computeRow(f,
/// family, count, offset, first) fills `arrays` row-scratch arrays for the `count` springs starting at
/// particle index `first`, which are then added to both ends (sign_second on the second) within the band.
template <typename ComputeRow>
void accumulateBand(int rows, int cols, const StencilFamily* families, int family_count, int arrays,
                    double* row_scratch, double* const* out, double sign_second, int row_begin, int row_end,
                    ComputeRow compute_row) {
  double* spring[kMaxRowArrays];
  for (int a = 0; a < arrays; ++a) spring[a] = row_scratch + static_cast<std::ptrdiff_t>(a) * cols;
  for (int r = firstSourceRow(row_begin); r < row_end; ++r) {
    for (int f = 0; f < family_count; ++f) {
      const StencilFamily& family = families[f];
      const ColumnRange range = springColumns(rows, cols, family, r);
      if (range.last <= range.first) continue;
      if (r < row_begin && r + family.dr < row_begin) continue;  // ends above the band
      const int offset = family.offset(cols);
      const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(r) * cols + range.first;
      compute_row(f, family, range.last - range.first, offset, first, spring);
      applyRow(cols, r, range, offset, row_begin, row_end, family.dr, arrays, spring, out, sign_second);
    }
  }
}

}  // namespace

void stencilAccumulateSpringForces(int rows, int cols, const StencilFamily* families, int family_count,
                                   ConstField positions_m, ConstField velocities_m_per_s, Field forces_N,
                                   double* row_scratch, int row_begin, int row_end) {
  double* const out[3] = {forces_N.x, forces_N.y, forces_N.z};
  const ConstField& x = positions_m;
  const ConstField& v = velocities_m_per_s;
  accumulateBand(rows, cols, families, family_count, 3, row_scratch, out, -1.0, row_begin, row_end,
                 [&](int, const StencilFamily& family, int count, int offset, std::ptrdiff_t first, double** spring) {
                   springForceRow(count, offset, family.stiffness_N_per_m, family.damping_N_s_per_m,
                                  family.rest_length_m, family.compression_cap_N, x.x + first, x.y + first,
                                  x.z + first, v.x + first, v.y + first, v.z + first, spring[0], spring[1],
                                  spring[2]);
                   clearMissingSprings(family, count, first, 3, spring);
                 });
}

void stencilLinearize(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                      double* inverse_length_per_m, double* transverse_stiffness_N_per_m, int row_begin,
                      int row_end) {
  const int offset = family.offset(cols);
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    if (range.last <= range.first) continue;
    const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(r) * cols + range.first;
    linearizeRow(range.last - range.first, offset, family.stiffness_N_per_m, family.rest_length_m,
                 family.compression_cap_N, positions_m.x + first, positions_m.y + first, positions_m.z + first,
                 inverse_length_per_m + first, transverse_stiffness_N_per_m + first);
    // A missing spring linearises to nothing: no direction and no transverse stiffness make its
    // differential and its blocks zero.
    double* linearised[2] = {inverse_length_per_m + first, transverse_stiffness_N_per_m + first};
    clearMissingSprings(family, range.last - range.first, first, 2, linearised);
  }
}

void stencilAccumulateDifferential(int rows, int cols, const StencilFamily* families, int family_count,
                                   ConstField linearized_positions_m, const double* const* inverse_length_per_m,
                                   const double* const* transverse_stiffness_N_per_m, ConstField w, double scale_x,
                                   double scale_v, Field df_N, double* row_scratch, int row_begin, int row_end) {
  double* const out[3] = {df_N.x, df_N.y, df_N.z};
  const ConstField& p = linearized_positions_m;
  accumulateBand(rows, cols, families, family_count, 3, row_scratch, out, -1.0, row_begin, row_end,
                 [&](int f, const StencilFamily& family, int count, int offset, std::ptrdiff_t first, double** spring) {
                   differentialRow(count, offset, family.stiffness_N_per_m, scale_v * family.damping_N_s_per_m,
                                   scale_x, p.x + first, p.y + first, p.z + first, inverse_length_per_m[f] + first,
                                   transverse_stiffness_N_per_m[f] + first, w.x + first, w.y + first, w.z + first,
                                   spring[0], spring[1], spring[2]);
                 });
}

void stencilAccumulateBlocks(int rows, int cols, const StencilFamily* families, int family_count,
                             ConstField linearized_positions_m, const double* const* inverse_length_per_m,
                             const double* const* transverse_stiffness_N_per_m, double scale_x, double scale_v,
                             double* const* blocks, double* row_scratch, int row_begin, int row_end) {
  const ConstField& p = linearized_positions_m;
  accumulateBand(rows, cols, families, family_count, kMaxRowArrays, row_scratch, blocks, 1.0, row_begin, row_end,
                 [&](int f, const StencilFamily& family, int count, int offset, std::ptrdiff_t first, double** spring) {
                   blockRow(count, offset, family.stiffness_N_per_m, scale_v * family.damping_N_s_per_m, scale_x,
                            p.x + first, p.y + first, p.z + first, inverse_length_per_m[f] + first,
                            transverse_stiffness_N_per_m[f] + first, spring[0], spring[1], spring[2], spring[3],
                            spring[4], spring[5]);
                 });
}

void stencilSpringBlocks(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                         const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                         double scale_x, double scale_v, double* const* blocks, int row_begin, int row_end) {
  const ConstField& p = linearized_positions_m;
  const int offset = family.offset(cols);
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    if (range.last <= range.first) continue;
    const std::ptrdiff_t first = static_cast<std::ptrdiff_t>(r) * cols + range.first;
    blockRow(range.last - range.first, offset, family.stiffness_N_per_m, scale_v * family.damping_N_s_per_m, scale_x,
             p.x + first, p.y + first, p.z + first, inverse_length_per_m + first, transverse_stiffness_N_per_m + first,
             blocks[0] + first, blocks[1] + first, blocks[2] + first, blocks[3] + first, blocks[4] + first,
             blocks[5] + first);
  }
}

}  // namespace cloth_sim::core
