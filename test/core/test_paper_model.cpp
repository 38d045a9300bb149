// Paper §2.3: what each spring kind is for. Without shear springs a cloth hung from one point collapses
// into a rope; without bend springs a cloth dropped on the floor crumples.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cloth_sim::core {
namespace {

/// Largest horizontal (x-y) distance between any two particles, m: the width of a hanging cloth seen
/// from above.
double horizontalWidth(const Eigen::Matrix3Xd& x) {
  double widest = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    for (Eigen::Index j = i + 1; j < x.cols(); ++j) {
      widest = std::max(widest, (x.col(i) - x.col(j)).head<2>().norm());
    }
  }
  return widest;
}

/// Mean fold angle, rad: for every particle with neighbours on both sides along a row or a column, the
/// angle between the two thread segments meeting there (0 where the thread runs straight). It is 0 for a
/// flat, smooth cloth and grows with every wrinkle, whatever the cloth's position or orientation.
double meanFoldAngle(const ClothGrid& grid, const Eigen::Matrix3Xd& x) {
  double sum = 0.0;
  int count = 0;
  const auto fold = [&](int a, int b, int c) {
    const Eigen::Vector3d first = x.col(b) - x.col(a);
    const Eigen::Vector3d second = x.col(c) - x.col(b);
    const double cosine = first.dot(second) / (first.norm() * second.norm());
    sum += std::acos(std::clamp(cosine, -1.0, 1.0));
    ++count;
  };
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      if (c + 2 < grid.cols) fold(grid.index(r, c), grid.index(r, c + 1), grid.index(r, c + 2));
      if (r + 2 < grid.rows) fold(grid.index(r, c), grid.index(r + 1, c), grid.index(r + 2, c));
    }
  }
  return sum / count;
}

/// The paper's §2.3 set-up: a 1 m square, hung from its top-left corner, damped so it settles.
double widthHungFromOneCorner(bool shear) {
  SceneOptions o;
  o.rows = 10;
  o.cols = 10;
  o.pins = {"top_left"};
  o.springs[static_cast<int>(SpringKind::kShear)].enabled = shear;
  o.air_damping_N_s_per_m = 0.02;  // settles within the run
  Simulation sim(o);
  for (int frame = 0; frame < 300; ++frame) sim.advanceFrame();  // 6 s
  return horizontalWidth(sim.state().positions_m);
}

TEST(PaperSection2_3, WithoutShearSpringsAClothHungFromOnePointCollapsesIntoARope) {
  const double original_m = 1.0;
  const double without_shear_m = widthHungFromOneCorner(false);
  const double with_shear_m = widthHungFromOneCorner(true);
  std::printf("[ paper 2.3  ] hung from one corner: width %.3f m without shear, %.3f m with shear\n",
              without_shear_m, with_shear_m);
  EXPECT_LT(without_shear_m, 0.1 * original_m) << "a rope: below a tenth of the original width";
  // With shear the square hangs as a diamond, its other two corners sqrt(2)/2 m either side of the pin.
  EXPECT_GT(with_shear_m, 1.2 * original_m);
}

/// Drops a 1 m square that starts upright on one edge and tilted 10 degrees, so it falls over onto the
/// floor; returns its mean fold angle once it lies still.
double foldAfterFallingOver(bool bend) {
  SceneOptions o;
  o.rows = 16;
  o.cols = 16;
  o.pins.clear();
  const double tilt = 10.0 * kPi / 180.0;
  o.origin_m = Eigen::Vector3d(-0.5, 0.0, 1.01);
  o.v_axis = Eigen::Vector3d(0.0, std::sin(tilt), -std::cos(tilt));  // bottom edge 1 cm above the floor
  o.springs[static_cast<int>(SpringKind::kBend)].enabled = bend;
  o.colliders.planes.push_back(PlaneCollider{});
  o.contact.friction = 0.5;
  o.air_damping_N_s_per_m = 0.005;
  Simulation sim(o);
  for (int frame = 0; frame < 200; ++frame) sim.advanceFrame();  // 4 s
  return meanFoldAngle(sim.grid(), sim.state().positions_m);
}

TEST(PaperSection2_3, WithoutBendSpringsAClothDroppedOnTheFloorCrumplesWithThemItStaysFlatter) {
  const double without_bend = foldAfterFallingOver(false);
  const double with_bend = foldAfterFallingOver(true);
  std::printf("[ paper 2.3  ] fallen on the floor: mean fold angle %.3f rad without bend, %.3f rad with bend\n",
              without_bend, with_bend);
  EXPECT_GT(without_bend, 3.0 * with_bend) << "bend springs keep it far flatter";
  EXPECT_GT(without_bend, 0.2) << "crumpled: threads fold by more than 0.2 rad at an average crossing";
}

}  // namespace
}  // namespace cloth_sim::core
