#include "cloth_sim/core/grid.h"

#include <stdexcept>

namespace cloth_sim::core {

const char* springKindName(SpringKind kind) {
  switch (kind) {
    case SpringKind::kStructural:
      return "structural";
    case SpringKind::kShear:
      return "shear";
    case SpringKind::kBend:
      return "bend";
  }
  return "unknown";
}

namespace {

void addSpring(const Eigen::Matrix3Xd& rest_m, int first, int second, SpringSet& set) {
  set.first.push_back(first);
  set.second.push_back(second);
  set.rest_length_m.push_back((rest_m.col(second) - rest_m.col(first)).norm());
}

}  // namespace

ClothGrid buildClothGrid(int rows, int cols, double width_m, double height_m, const Eigen::Vector3d& origin_m,
                         const Eigen::Vector3d& u_axis, const Eigen::Vector3d& v_axis,
                         const std::vector<std::uint8_t>& active) {
  if (rows < 2 || cols < 2) throw std::invalid_argument("a cloth grid needs at least 2 x 2 particles");
  ClothGrid grid;
  grid.rows = rows;
  grid.cols = cols;
  const int count = rows * cols;
  if (!active.empty() && static_cast<int>(active.size()) != count) {
    throw std::invalid_argument("the active mask needs one entry per particle");
  }
  grid.active = active;
  const double du_m = width_m / (cols - 1);
  const double dv_m = height_m / (rows - 1);
  grid.rest_positions_m.resize(3, count);
  grid.uv.resize(2, count);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = grid.index(r, c);
      grid.rest_positions_m.col(i) = origin_m + c * du_m * u_axis + r * dv_m * v_axis;
      grid.uv.col(i) = Eigen::Vector2d(static_cast<double>(c) / (cols - 1), static_cast<double>(r) / (rows - 1));
    }
  }
  const Eigen::Matrix3Xd& rest = grid.rest_positions_m;
  SpringSet& structural = grid.springs[static_cast<int>(SpringKind::kStructural)];
  SpringSet& shear = grid.springs[static_cast<int>(SpringKind::kShear)];
  SpringSet& bend = grid.springs[static_cast<int>(SpringKind::kBend)];
  // Outside an outline a particle has no springs and no triangles.
  const auto spring = [&](int first, int second, SpringSet& set) {
    if (grid.isActive(first) && grid.isActive(second)) addSpring(rest, first, second, set);
  };
  const auto triangle = [&](int a, int b, int c) {
    if (grid.isActive(a) && grid.isActive(b) && grid.isActive(c)) grid.triangles.insert(grid.triangles.end(), {a, b, c});
  };
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const int i = grid.index(r, c);
      if (c + 1 < cols) spring(i, grid.index(r, c + 1), structural);
      if (r + 1 < rows) spring(i, grid.index(r + 1, c), structural);
      if (r + 1 < rows && c + 1 < cols) {
        spring(i, grid.index(r + 1, c + 1), shear);
        spring(grid.index(r, c + 1), grid.index(r + 1, c), shear);
        // Two triangles per quad, counter-clockwise seen from u x v.
        const int right = grid.index(r, c + 1);
        const int below = grid.index(r + 1, c);
        const int diagonal = grid.index(r + 1, c + 1);
        triangle(i, right, diagonal);
        triangle(i, diagonal, below);
      }
      if (c + 2 < cols) spring(i, grid.index(r, c + 2), bend);
      if (r + 2 < rows) spring(i, grid.index(r + 2, c), bend);
    }
  }
  return grid;
}

}  // namespace cloth_sim::core
