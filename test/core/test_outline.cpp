// Issue 17, section 3: non-rectangular outlines. Particles outside are removed with their springs and
// triangles (they stay in the arrays, frozen where they started); the mass, the curvature term and the
// contacts follow; and the Cusick drape test, which needs a disc, measures something physical with them.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/mesh_check.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/textile_tests.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace cloth_sim::core {
namespace {

using test::preset;

SceneOptions disc(int side, bool material) {
  SceneOptions scene;
  scene.rows = side;
  scene.cols = side;
  scene.width_m = 1.0;
  scene.height_m = 1.0;
  scene.outline.shape = OutlineOptions::Shape::kCircle;
  scene.outline.center_m = Eigen::Vector2d(0.5, 0.5);
  scene.outline.radius_m = 0.5;
  scene.pins = {std::to_string((side / 2) * side + side / 2)};  // the centre
  scene.u_axis = Eigen::Vector3d::UnitX();  // horizontal: hung from its centre, it falls around it
  scene.v_axis = Eigen::Vector3d::UnitY();
  if (material) {
    scene.has_material = true;
    scene.material = preset("cotton");
    scene.bend_model = BendModel::kCurvature;
  }
  return scene;
}

TEST(Outline, ACircleKeepsTheParticlesInsideWithOnlyTheirSpringsAndTriangles) {
  const SceneOptions scene = disc(21, false);
  ASSERT_TRUE(validateSceneOptions(scene).empty());
  Simulation simulation(scene);
  const ClothGrid& grid = simulation.grid();
  int inside = 0;
  for (int r = 0; r < 21; ++r) {
    for (int c = 0; c < 21; ++c) {
      const bool expected = std::hypot(c * 0.05 - 0.5, r * 0.05 - 0.5) <= 0.5 + 1e-12;
      EXPECT_EQ(grid.isActive(grid.index(r, c)), expected) << r << ", " << c;
      inside += expected ? 1 : 0;
    }
  }
  EXPECT_GT(inside, 300);
  EXPECT_LT(inside, 21 * 21);
  for (const SpringSet& springs : grid.springs) {
    for (std::size_t s = 0; s < springs.size(); ++s) {
      EXPECT_TRUE(grid.isActive(springs.first[s]) && grid.isActive(springs.second[s]));
    }
  }
  for (const int corner : grid.triangles) EXPECT_TRUE(grid.isActive(corner));
  // The paper's mass is shared by the particles inside.
  double inside_kg = 0.0;
  for (int p = 0; p < grid.particleCount(); ++p) inside_kg += grid.isActive(p) ? simulation.massPerParticle_kg()[p] : 0.0;
  EXPECT_NEAR(inside_kg, scene.mass_kg, 1e-12);
}

TEST(Outline, ParticlesOutsideNeverMoveAndTheStencilMatchesTheEdgeListSprings) {
  // Hung from its centre, the disc falls around it; the particles outside stay where they started, and
  // the stencil kernels' forces (with the removed springs masked) equal the edge-list oracle's.
  Simulation simulation(disc(17, false));
  const ClothGrid& grid = simulation.grid();
  for (int frame = 0; frame < 25; ++frame) ASSERT_TRUE(simulation.advanceFrame().stable);
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  double moved_inside_m = 0.0;
  for (int p = 0; p < grid.particleCount(); ++p) {
    const double moved_m = (x.col(p) - grid.rest_positions_m.col(p)).norm();
    if (grid.isActive(p)) {
      moved_inside_m = std::max(moved_inside_m, moved_m);
    } else {
      EXPECT_EQ(moved_m, 0.0) << p;
    }
  }
  EXPECT_GT(moved_inside_m, 0.1) << "the disc fell around its centre";
  SceneOptions springs_only = simulation.options();
  springs_only.gravity_m_per_s2.setZero();
  springs_only.air_damping_N_s_per_m = 0.0;
  Simulation model(springs_only);
  const Eigen::Matrix3Xd v = Eigen::Matrix3Xd::Random(3, grid.particleCount());
  Eigen::Matrix3Xd stencil = Eigen::Matrix3Xd::Zero(3, grid.particleCount());
  model.forceModel().forces(x, v, 0.0, stencil);
  Eigen::Matrix3Xd oracle = Eigen::Matrix3Xd::Zero(3, grid.particleCount());
  for (int k = 0; k < kSpringKindCount; ++k) {
    accumulateSpringForces(grid.springs[k], springs_only.springs[k], x, v, oracle);
  }
  EXPECT_LT((stencil - oracle).cwiseAbs().maxCoeff(), 1e-9 * oracle.cwiseAbs().maxCoeff());
}

TEST(Outline, AMaterialDiscWeighsItsAreaAndItsImplicitSystemIsConsistent) {
  const SceneOptions scene = disc(25, true);
  Simulation simulation(scene);
  const ClothGrid& grid = simulation.grid();
  // Mass: density x the area of the triangles kept (a triangle is kept when its three corners are inside,
  // so the disc is cut inside its circle: 12 % short of pi r^2 at 25 x 25, less on finer grids).
  double inside_kg = 0.0;
  for (int p = 0; p < grid.particleCount(); ++p) inside_kg += grid.isActive(p) ? simulation.massPerParticle_kg()[p] : 0.0;
  const double kept_m2 = static_cast<double>(grid.triangles.size() / 3) * 0.5 * (1.0 / 24) * (1.0 / 24);
  EXPECT_NEAR(inside_kg, scene.material.areal_density_kg_per_m2 * kept_m2, 1e-12);
  EXPECT_NEAR(kept_m2, kPi * 0.25, 0.15 * kPi * 0.25);
  // The assembled matrix (multigrid) equals the matrix-free product with springs and curvature masked.
  ClothForceModel& model = simulation.forceModel();
  const Eigen::Matrix3Xd x = grid.rest_positions_m + 0.01 * Eigen::Matrix3Xd::Random(3, grid.particleCount());
  model.linearize(x, Eigen::Matrix3Xd::Zero(3, grid.particleCount()), 0.0);
  GridBlockMatrix matrix;
  ASSERT_TRUE(model.systemGridMatrix(0.02, matrix));
  const Eigen::Matrix3Xd w = Eigen::Matrix3Xd::Random(3, grid.particleCount());
  Eigen::Matrix3Xd free_product, assembled;
  model.systemProduct(0.02, w, free_product);
  matrix.multiply(w, assembled, 1);
  EXPECT_LT((free_product - assembled).cwiseAbs().maxCoeff(), 1e-9 * free_product.cwiseAbs().maxCoeff());
}

TEST(Outline, MistakesAreRefusedByName) {
  SceneOptions scene = disc(11, false);
  scene.pins = {"top_left"};  // a corner of the square, outside the circle
  ASSERT_FALSE(validateSceneOptions(scene).empty());
  EXPECT_NE(validateSceneOptions(scene).front().find("pins: particle 0 is outside the outline"), std::string::npos);
  scene = disc(11, false);
  scene.outline.center_m = Eigen::Vector2d(5.0, 5.0);
  scene.pins.clear();
  EXPECT_NE(validateSceneOptions(scene).front().find("outline: keeps no triangle"), std::string::npos);
  scene.outline.shape = OutlineOptions::Shape::kPolygon;
  scene.outline.vertices_m = {{0.0, 0.0}, {1.0, 0.0}};
  EXPECT_NE(validateSceneOptions(scene).front().find("outline.polygon: 2 corners"), std::string::npos);
  scene.outline.vertices_m = {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}};  // a triangle: half the square
  EXPECT_TRUE(validateSceneOptions(scene).empty());
  Simulation half(scene);
  EXPECT_TRUE(half.grid().isActive(half.grid().index(5, 5))) << "on the outline counts as inside";
  EXPECT_FALSE(half.grid().isActive(half.grid().index(10, 10)));
  std::string error;
  GraspRequest grab;
  grab.particle = half.grid().index(10, 10);
  EXPECT_FALSE(half.grab(grab, &error));
  EXPECT_NE(error.find("outside the cloth's outline"), std::string::npos) << error;
  // A grab at the nearest particle never picks one outside.
  grab.particle = -1;
  grab.target_m = half.grid().rest_positions_m.col(half.grid().index(10, 10));
  ASSERT_TRUE(half.grab(grab, &error)) << error;
  EXPECT_TRUE(half.grid().isActive(half.grasps().front().particle));
}

/// The triangle under the square's diagonal on an 11 x 11 grid: particles (10, 0) and (0, 10) are inside
/// it (on its corners) but in none of the triangles it keeps, since the grid's diagonals run the other way.
SceneOptions halfSquare(bool material) {
  SceneOptions scene = disc(11, material);
  scene.outline.shape = OutlineOptions::Shape::kPolygon;
  scene.outline.vertices_m = {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}};
  scene.pins = {"top_left"};
  return scene;
}

TEST(Outline, AParticleInsideButInNoKeptTriangleIsRemovedLikeOneOutside) {
  // A material gives each particle the area of its kept triangles: these two had none, so no mass, and
  // the guard's k / m for them was infinite: every frame was rolled back and the scene reset for good
  // (`cloth_bench` on this scene: 37 of 50 frames rolled back). Removed, the particles, springs and
  // triangles the outline keeps are one set, with the paper's constants too.
  for (const bool material : {true, false}) {
    const SceneOptions scene = halfSquare(material);
    ASSERT_TRUE(validateSceneOptions(scene).empty()) << validateSceneOptions(scene).front();
    Simulation simulation(scene);
    const ClothGrid& grid = simulation.grid();
    EXPECT_FALSE(grid.isActive(grid.index(10, 0))) << material;
    EXPECT_FALSE(grid.isActive(grid.index(0, 10))) << material;
    std::vector<bool> in_triangle(static_cast<std::size_t>(grid.particleCount()), false);
    for (const int corner : grid.triangles) in_triangle[static_cast<std::size_t>(corner)] = true;
    int active = 0;
    double cloth_kg = 0.0;
    for (int p = 0; p < grid.particleCount(); ++p) {
      EXPECT_EQ(grid.isActive(p), in_triangle[static_cast<std::size_t>(p)]) << p;
      if (!grid.isActive(p)) continue;
      ++active;
      cloth_kg += simulation.massPerParticle_kg()[p];
      EXPECT_GT(simulation.massPerParticle_kg()[p], 0.0) << p;
    }
    EXPECT_EQ(active, 11 * 12 / 2 - 2);
    EXPECT_NEAR(cloth_kg, simulation.options().mass_kg, 1e-12 * simulation.options().mass_kg);
    for (const SpringSet& springs : grid.springs) {
      for (std::size_t s = 0; s < springs.size(); ++s) {
        EXPECT_TRUE(grid.isActive(springs.first[s]) && grid.isActive(springs.second[s]));
      }
    }
    int rolled_back = 0;
    for (int frame = 0; frame < 50; ++frame) rolled_back += simulation.advanceFrame().stable ? 0 : 1;
    EXPECT_EQ(rolled_back, 0) << (material ? "cotton" : "the paper's constants");
  }
  // A pin on such a particle is refused as one outside.
  SceneOptions scene = halfSquare(true);
  scene.pins = {"bottom_left"};
  const std::vector<std::string> problems = validateSceneOptions(scene);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems.front(), "pins: particle 110 is outside the outline (or in none of the triangles it keeps)");
}

/// The even-odd rule over every edge, written plainly: a particle within `tolerance` of an edge is inside.
bool insideByEveryEdge(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& point, double tolerance) {
  bool inside = false;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[(i + polygon.size() - 1) % polygon.size()];
    const double t = std::clamp((point - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
    if ((a + t * (b - a) - point).norm() <= tolerance) return true;
    if ((a.y() > point.y()) != (b.y() > point.y()) &&
        point.x() < (b.x() - a.x()) * (point.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

TEST(Outline, AManyCorneredPolygonKeepsWhatEveryEdgeSays) {
  // outlineMask tests each row of particles only against the edges whose v range reaches it (a 4096-corner
  // outline took seconds to load at 256 x 256): the mask must be the one every edge gives. A star of 1000
  // corners, and a diamond whose corners and edges pass exactly through particles (the on-the-line rule).
  constexpr int kSide = 41;
  constexpr double kSpacing_m = 1.0 / (kSide - 1);
  std::vector<Eigen::Vector2d> star;
  constexpr int kStarCorners = 1000;
  for (int k = 0; k < kStarCorners; ++k) {
    const double angle = 2.0 * kPi * k / kStarCorners;
    const double radius_m = k % 2 == 0 ? 0.45 : 0.3;
    star.emplace_back(0.5 + radius_m * std::cos(angle), 0.5 + radius_m * std::sin(angle));
  }
  const std::vector<Eigen::Vector2d> diamond = {{0.5, 0.0}, {1.0, 0.5}, {0.5, 1.0}, {0.0, 0.5}};
  for (const std::vector<Eigen::Vector2d>& polygon : {star, diamond}) {
    SceneOptions scene;
    scene.rows = scene.cols = kSide;
    scene.width_m = scene.height_m = 1.0;
    scene.pins = {};
    const ClothGrid full = Simulation(scene).grid();
    scene.outline.shape = OutlineOptions::Shape::kPolygon;
    scene.outline.vertices_m = polygon;
    std::vector<bool> inside(static_cast<std::size_t>(kSide) * kSide);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) {
        inside[static_cast<std::size_t>(r) * kSide + c] =
            insideByEveryEdge(polygon, Eigen::Vector2d(c * kSpacing_m, r * kSpacing_m), 1e-9 * kSpacing_m);
      }
    }
    // Kept: a corner of a triangle whose three corners are inside.
    std::vector<std::uint8_t> expected(inside.size(), 0);
    for (std::size_t t = 0; t + 2 < full.triangles.size(); t += 3) {
      const int a = full.triangles[t], b = full.triangles[t + 1], c = full.triangles[t + 2];
      if (inside[a] && inside[b] && inside[c]) expected[a] = expected[b] = expected[c] = 1;
    }
    const std::vector<std::uint8_t> mask = outlineMask(scene);
    EXPECT_EQ(mask, expected) << polygon.size() << " corners";
    EXPECT_GT(std::count(mask.begin(), mask.end(), 1), kSide * kSide / 4) << polygon.size() << " corners";
  }
}

TEST(Outline, EnergiesCountOnlyTheCloth) {
  // The particles outside keep a mass so that nothing divides by zero, but they are not cloth: a flat disc
  // of the paper's 0.5 kg at 1 m weighed 625 shares of 0.5 / 441 kg in its potential energy (6.95 J).
  SceneOptions scene = disc(25, false);
  scene.origin_m = Eigen::Vector3d(0.0, 0.0, 1.0);
  scene.pins.clear();
  constexpr double kHeight_m = 1.0;
  const double g_m_per_s2 = -scene.gravity_m_per_s2.z();
  Simulation paper(scene);
  EXPECT_NEAR(paper.energies().potential_J, scene.mass_kg * g_m_per_s2 * kHeight_m, 1e-12);
  EXPECT_EQ(paper.energies().kinetic_J, 0.0);
  // A material disc weighs its kept area.
  scene.has_material = true;
  scene.material = preset("cotton");
  Simulation cotton(scene);
  const double kept_m2 = static_cast<double>(cotton.grid().triangles.size() / 3) * 0.5 * (1.0 / 24) * (1.0 / 24);
  EXPECT_NEAR(cotton.energies().potential_J,
              scene.material.areal_density_kg_per_m2 * kept_m2 * g_m_per_s2 * kHeight_m, 1e-12);
}

TEST(Outline, AnInvalidOutlineInAMaterialSceneIsReportedByItsOwnReasonAlone) {
  // The material's mass used to be derived from the area a bad outline keeps (none), and reported first:
  // "material gives mass = 0: must be in [1e-06, 10000]".
  SceneOptions scene = disc(11, true);
  scene.outline.radius_m = -1.0;
  EXPECT_EQ(validateSceneOptions(scene), std::vector<std::string>{"outline.circle.radius = -1: must be in (0, 100]"});
  scene.outline.radius_m = 0.5;
  scene.outline.center_m = Eigen::Vector2d(5.0, 5.0);
  scene.pins.clear();
  const std::vector<std::string> problems = validateSceneOptions(scene);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems.front().rfind("outline: keeps no triangle", 0), 0u) << problems.front();
}

TEST(Cusick, TheProjectedAreaOfAFlatDiscIsItsAreaAndFoldsAreCounted) {
  // A flat specimen's shadow is the kept triangles' area; DC is then 100 %.
  const SceneOptions scene = cusickScene(preset("denim"), BendModel::kCurvature, 41);
  Simulation flat(scene);
  const ClothGrid& grid = flat.grid();
  const double spacing_m = kCusickSpecimenDiameter_m / 40;
  const double kept_m2 = static_cast<double>(grid.triangles.size() / 3) * 0.5 * spacing_m * spacing_m;
  EXPECT_NEAR(projectedArea_m2(grid.triangles, grid.rest_positions_m, 2e-4), kept_m2, 0.01 * kept_m2);
  EXPECT_EQ(countFolds(grid, grid.rest_positions_m, Eigen::Vector2d::Zero()), 0) << "a flat disc has no folds";
  // A hem waved six times round has six crests.
  Eigen::Matrix3Xd waved = grid.rest_positions_m;
  for (int p = 0; p < grid.particleCount(); ++p) {
    const Eigen::Vector2d d = waved.col(p).head<2>();
    const double scale = 1.0 - 0.15 * (d.norm() / 0.15) * (0.5 + 0.5 * std::cos(6.0 * std::atan2(d.y(), d.x())));
    waved.col(p).head<2>() = d * scale;
  }
  EXPECT_EQ(countFolds(grid, waved, Eigen::Vector2d::Zero()), 6);
}

TEST(Cusick, StifferFabricsDrapeLessAndEveryPresetFolds) {
  // A coarse specimen (31 x 31, 1 cm spacing) for 4 s: denim, the stiffest, keeps the widest shadow, silk the
  // narrowest; each drapes (DC below 100 %) into folds. doc/VALIDATION.md has the full-size test.
  double dc_denim = 0.0;
  double dc_silk = 0.0;
  for (const char* name : {"denim", "silk"}) {
    const CusickMeasurement measured = runCusick(cusickScene(preset(name), BendModel::kCurvature, 31), 4.0);
    std::printf("[ cusick     ] %s at 31 x 31: DC %.1f %%, %d folds\n", name, 100 * measured.drape_coefficient,
                measured.folds);
    EXPECT_GT(measured.drape_coefficient, 0.2) << name;
    EXPECT_LT(measured.drape_coefficient, 0.98) << name;
    EXPECT_GE(measured.folds, 3) << name;
    (std::string(name) == "denim" ? dc_denim : dc_silk) = measured.drape_coefficient;
  }
  EXPECT_GT(dc_denim, dc_silk + 0.05);
}

}  // namespace
}  // namespace cloth_sim::core
