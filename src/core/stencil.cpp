#include "cloth_sim/core/stencil.h"

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

/// Zeroes the slots of row r outside [range.first, range.last) in `arrays` arrays (shifted by shift).
void zeroOutside(int cols, int row, ColumnRange range, int shift, double* const* arrays, int count) {
  const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(row) * cols + shift;
  for (int a = 0; a < count; ++a) {
    double* slot = arrays[a] + base;
    std::fill(slot, slot + range.first, 0.0);
    std::fill(slot + std::max(range.last, range.first), slot + cols, 0.0);
  }
}

/// Zeroes the slots before the first spring's (no spring ends at the first `offset` particles), once per
/// pass: by the band that holds row 0.
void zeroLeading(int row_begin, int offset, double* const* arrays, int count) {
  if (row_begin != 0) return;
  for (int a = 0; a < count; ++a) std::fill(arrays[a], arrays[a] + offset, 0.0);
}

/// 1 / l, or 0 for a spring too short to have a direction (it then exerts nothing).
inline double inverseLength(double length_m) {
  return length_m > kStencilDegenerateLength_m ? 1.0 / length_m : 0.0;
}

}  // namespace

void stencilSpringForces(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                         ConstField velocities_m_per_s, Field spring_force_N, int row_begin, int row_end) {
  const int offset = family.offset(cols);
  const double ks = family.stiffness_N_per_m;
  const double kd = family.damping_N_s_per_m;
  const double rest = family.rest_length_m;
  const double* __restrict px = positions_m.x;
  const double* __restrict py = positions_m.y;
  const double* __restrict pz = positions_m.z;
  const double* __restrict vx = velocities_m_per_s.x;
  const double* __restrict vy = velocities_m_per_s.y;
  const double* __restrict vz = velocities_m_per_s.z;
  double* __restrict fx = spring_force_N.x + offset;
  double* __restrict fy = spring_force_N.y + offset;
  double* __restrict fz = spring_force_N.z + offset;
  double* const arrays[3] = {spring_force_N.x, spring_force_N.y, spring_force_N.z};
  zeroLeading(row_begin, offset, arrays, 3);
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    zeroOutside(cols, r, range, offset, arrays, 3);
    const std::ptrdiff_t row_start = static_cast<std::ptrdiff_t>(r) * cols;
    for (std::ptrdiff_t i = row_start + range.first; i < row_start + range.last; ++i) {
      const std::ptrdiff_t j = i + offset;
      const double dx = px[j] - px[i];
      const double dy = py[j] - py[i];
      const double dz = pz[j] - pz[i];
      const double length = std::sqrt(dx * dx + dy * dy + dz * dz);
      const double inverse = inverseLength(length);
      const double separation_rate = ((vx[j] - vx[i]) * dx + (vy[j] - vy[i]) * dy + (vz[j] - vz[i]) * dz) * inverse;
      const double magnitude = (ks * (length - rest) + kd * separation_rate) * inverse;
      fx[i] = magnitude * dx;
      fy[i] = magnitude * dy;
      fz[i] = magnitude * dz;
    }
  }
}

void stencilLinearize(int rows, int cols, const StencilFamily& family, ConstField positions_m,
                      double* inverse_length_per_m, double* transverse_stiffness_N_per_m, int row_begin,
                      int row_end) {
  const int offset = family.offset(cols);
  const double ks = family.stiffness_N_per_m;
  const double rest = family.rest_length_m;
  const double* __restrict px = positions_m.x;
  const double* __restrict py = positions_m.y;
  const double* __restrict pz = positions_m.z;
  double* __restrict inv = inverse_length_per_m;
  double* __restrict transverse = transverse_stiffness_N_per_m;
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    const std::ptrdiff_t row_start = static_cast<std::ptrdiff_t>(r) * cols;
    for (std::ptrdiff_t i = row_start + range.first; i < row_start + range.last; ++i) {
      const std::ptrdiff_t j = i + offset;
      const double dx = px[j] - px[i];
      const double dy = py[j] - py[i];
      const double dz = pz[j] - pz[i];
      const double inverse = inverseLength(std::sqrt(dx * dx + dy * dy + dz * dz));
      inv[i] = inverse;
      transverse[i] = ks * std::max(0.0, 1.0 - rest * inverse);
    }
  }
}

void stencilSpringDifferential(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                               const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                               ConstField dx, double scale_x, ConstField dv, double scale_v, Field spring_force_N,
                               int row_begin, int row_end) {
  const int offset = family.offset(cols);
  const double ks = family.stiffness_N_per_m;
  const double kd_scaled = scale_v * family.damping_N_s_per_m;
  const double* __restrict px = linearized_positions_m.x;
  const double* __restrict py = linearized_positions_m.y;
  const double* __restrict pz = linearized_positions_m.z;
  const double* __restrict inv = inverse_length_per_m;
  const double* __restrict transverse = transverse_stiffness_N_per_m;
  const double* __restrict ax = dx.x;
  const double* __restrict ay = dx.y;
  const double* __restrict az = dx.z;
  const double* __restrict bx = dv.x;
  const double* __restrict by = dv.y;
  const double* __restrict bz = dv.z;
  double* __restrict fx = spring_force_N.x + offset;
  double* __restrict fy = spring_force_N.y + offset;
  double* __restrict fz = spring_force_N.z + offset;
  double* const arrays[3] = {spring_force_N.x, spring_force_N.y, spring_force_N.z};
  zeroLeading(row_begin, offset, arrays, 3);
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    zeroOutside(cols, r, range, offset, arrays, 3);
    const std::ptrdiff_t row_start = static_cast<std::ptrdiff_t>(r) * cols;
    for (std::ptrdiff_t i = row_start + range.first; i < row_start + range.last; ++i) {
      const std::ptrdiff_t j = i + offset;
      const double ux = (px[j] - px[i]) * inv[i];
      const double uy = (py[j] - py[i]) * inv[i];
      const double uz = (pz[j] - pz[i]) * inv[i];
      const double dax = ax[j] - ax[i];
      const double day = ay[j] - ay[i];
      const double daz = az[j] - az[i];
      const double dbx = bx[j] - bx[i];
      const double dby = by[j] - by[i];
      const double dbz = bz[j] - bz[i];
      const double a = scale_x * transverse[i];
      const double along = scale_x * (ks - transverse[i]) * (ux * dax + uy * day + uz * daz) +
                           kd_scaled * (ux * dbx + uy * dby + uz * dbz);
      fx[i] = a * dax + along * ux;
      fy[i] = a * day + along * uy;
      fz[i] = a * daz + along * uz;
    }
  }
}

void stencilSpringBlocks(int rows, int cols, const StencilFamily& family, ConstField linearized_positions_m,
                         const double* inverse_length_per_m, const double* transverse_stiffness_N_per_m,
                         double scale_x, double scale_v, const std::array<double*, 6>& blocks, int row_begin,
                         int row_end) {
  const int offset = family.offset(cols);
  const double ks = family.stiffness_N_per_m;
  const double kd_scaled = scale_v * family.damping_N_s_per_m;
  const double* __restrict px = linearized_positions_m.x;
  const double* __restrict py = linearized_positions_m.y;
  const double* __restrict pz = linearized_positions_m.z;
  const double* __restrict inv = inverse_length_per_m;
  const double* __restrict transverse = transverse_stiffness_N_per_m;
  double* __restrict bxx = blocks[0] + offset;
  double* __restrict byy = blocks[1] + offset;
  double* __restrict bzz = blocks[2] + offset;
  double* __restrict bxy = blocks[3] + offset;
  double* __restrict bxz = blocks[4] + offset;
  double* __restrict byz = blocks[5] + offset;
  zeroLeading(row_begin, offset, blocks.data(), 6);
  for (int r = row_begin; r < row_end; ++r) {
    const ColumnRange range = springColumns(rows, cols, family, r);
    zeroOutside(cols, r, range, offset, blocks.data(), 6);
    const std::ptrdiff_t row_start = static_cast<std::ptrdiff_t>(r) * cols;
    for (std::ptrdiff_t i = row_start + range.first; i < row_start + range.last; ++i) {
      const std::ptrdiff_t j = i + offset;
      const double ux = (px[j] - px[i]) * inv[i];
      const double uy = (py[j] - py[i]) * inv[i];
      const double uz = (pz[j] - pz[i]) * inv[i];
      const double a = scale_x * transverse[i];
      const double along = scale_x * (ks - transverse[i]) + kd_scaled;
      bxx[i] = a + along * ux * ux;
      byy[i] = a + along * uy * uy;
      bzz[i] = a + along * uz * uz;
      bxy[i] = along * ux * uy;
      bxz[i] = along * ux * uz;
      byz[i] = along * uy * uz;
    }
  }
}

void stencilGather(int offset, const double* const* slots, double* const* out, int arrays, double sign_end,
                   std::ptrdiff_t begin, std::ptrdiff_t end) {
  for (int a = 0; a < arrays; ++a) {
    const double* __restrict slot = slots[a];
    double* __restrict target = out[a];
    for (std::ptrdiff_t i = begin; i < end; ++i) target[i] += slot[offset + i] + sign_end * slot[i];
  }
}

}  // namespace cloth_sim::core
