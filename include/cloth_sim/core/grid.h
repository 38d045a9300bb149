// Rest geometry and topology of the particle grid (paper §2). Built once per scene, then read-only.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cloth_sim::core {

/// The paper's three spring kinds. Each kind has its own stiffness and damping (SpringOptions).
enum class SpringKind { kStructural = 0, kShear = 1, kBend = 2 };
constexpr int kSpringKindCount = 3;

/// "structural", "shear" or "bend": the names used in scene files and parameters.
const char* springKindName(SpringKind kind);

/// All springs of one kind as parallel flat arrays, one entry per spring.
struct SpringSet {
  std::vector<int> first;             ///< particle index of one end
  std::vector<int> second;            ///< particle index of the other end
  std::vector<double> rest_length_m;  ///< rest length, m, measured on the initial grid

  std::size_t size() const { return first.size(); }
};

/// A rows x cols particle grid. Particle (row, col) has index row * cols + col; row 0 is the top edge,
/// column 0 the left edge. Positions are in the world frame, metres.
struct ClothGrid {
  int rows = 0;
  int cols = 0;
  /// Indexed by SpringKind: structural (4-neighbours), shear (both quad diagonals), bend (two apart).
  std::array<SpringSet, kSpringKindCount> springs;
  /// Three particle indices per triangle, two triangles per quad, counter-clockwise seen from the side
  /// u_axis x v_axis points to.
  std::vector<int> triangles;
  Eigen::Matrix2Xd uv;                ///< texture coordinate per particle, in [0, 1]^2
  Eigen::Matrix3Xd rest_positions_m;  ///< initial position per particle, world frame, m
  /// 1 per particle the scene's outline keeps (outlineMask: inside it and a corner of a triangle inside
  /// it), 0 for the rest (issue 17); empty: every particle is in. A removed particle keeps its place in the arrays (the stencil kernels and multigrid work on the whole
  /// rectangle) but has no springs, no triangles and no mass that moves: it stays where it started.
  std::vector<std::uint8_t> active;

  int particleCount() const { return rows * cols; }
  bool isActive(int particle) const { return active.empty() || active[static_cast<std::size_t>(particle)] != 0; }
  bool hasOutline() const { return !active.empty(); }
  int index(int row, int col) const { return row * cols + col; }
  const SpringSet& springsOf(SpringKind kind) const { return springs[static_cast<int>(kind)]; }
};

/// Lays the grid out flat: particle (r, c) sits at origin + c * du * u_axis + r * dv * v_axis with
/// du = width / (cols - 1), dv = height / (rows - 1). u_axis and v_axis must be unit and orthogonal.
/// `active` (empty, or one entry per particle): the particles inside an outline; springs and triangles
/// are built between active particles only.
ClothGrid buildClothGrid(int rows, int cols, double width_m, double height_m, const Eigen::Vector3d& origin_m,
                         const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                         const std::vector<std::uint8_t>& active = {});

}  // namespace cloth_sim::core
