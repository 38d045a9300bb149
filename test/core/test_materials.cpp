// Issue 17: materials in physical units. The mapping to spring constants is checked against the sheet
// it should be (a uniform stretch and shear of the grid give the material's moduli, at any resolution),
// the curvature term against its energy and its invariances, and the cantilever against the heavy
// elastica, which the test solves itself.
#include "cloth_sim/core/force_model.h"
#include "cloth_sim/core/material.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/textile_tests.h"
#include "scene_test_util.h"
#include "cloth_sim/io/scene_file.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cloth_sim::core {
namespace {

using test::preset;

/// A flat material sheet in the xy plane, no gravity, nothing pinned.
SceneOptions sheet(const MaterialOptions& material, int side, BendModel bend_model = BendModel::kSprings) {
  SceneOptions scene;
  scene.rows = side;
  scene.cols = side;
  scene.width_m = 0.5;
  scene.height_m = 0.5;
  scene.origin_m = Eigen::Vector3d::Zero();
  scene.u_axis = Eigen::Vector3d::UnitX();
  scene.v_axis = Eigen::Vector3d::UnitY();
  scene.gravity_m_per_s2.setZero();
  scene.pins.clear();
  scene.has_material = true;
  scene.material = material;
  scene.bend_model = bend_model;
  return scene;
}

/// Forces of the material's springs and bending in a given configuration (zero velocity).
Eigen::Matrix3Xd elasticForces(Simulation& simulation, const Eigen::Matrix3Xd& positions_m) {
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, positions_m.cols());
  simulation.forceModel().forces(positions_m, Eigen::Matrix3Xd::Zero(3, positions_m.cols()), 0.0, forces);
  return forces;
}

/// The force per unit width, N/m, that the particles right of the vertical line between columns
/// cut - 1 and cut pull the rest with (the sum of the left part's forces, over the rows' width).
Eigen::Vector3d tractionAcross(const Eigen::Matrix3Xd& forces, int rows, int cols, int cut, double spacing_m) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cut; ++c) sum += forces.col(r * cols + c);
  }
  return sum / (rows * spacing_m);  // each row carries one row spacing of width
}

TEST(MaterialMapping, UniaxialStretchGivesTheStretchModulusAtEveryResolution) {
  // A strip test: strain e along u, the sheet free to contract across (by the lattice's Poisson ratio
  // C12 / C11): the pull per width is Y e, and every particle away from the clamps is in balance.
  const MaterialOptions cotton = preset("cotton");
  constexpr double kStrain = 1e-5;
  for (const int side : {10, 20, 40}) {
    Simulation simulation(sheet(cotton, side));
    const MaterialConstants constants =
        materialConstants(cotton, BendModel::kSprings, side, side, 0.5, 0.5, 0.0);
    const double c11 = constants.springs[0].stiffness_N_per_m + constants.springs[1].stiffness_N_per_m +
                       4.0 * constants.springs[2].stiffness_N_per_m;
    const double poisson = constants.springs[1].stiffness_N_per_m / c11;
    Eigen::Matrix3Xd stretched = simulation.grid().rest_positions_m;
    stretched.row(0) *= 1.0 + kStrain;
    stretched.row(1) *= 1.0 - poisson * kStrain;
    const Eigen::Matrix3Xd forces = elasticForces(simulation, stretched);
    const double spacing_m = 0.5 / (side - 1);
    const Eigen::Vector3d traction = tractionAcross(forces, side, side, side / 2, spacing_m);
    // The right half pulls the left one (+x). Every row of particles carries a full row of structural
    // springs, the edge rows too: per row, the pull is the modulus (over the sheet's width (rows - 1) h
    // it is rows / (rows - 1) times it, the lattice's edge excess, doc/PHYSICS.md).
    EXPECT_NEAR(traction.x() / kStrain, cotton.stretch_modulus_N_per_m, 1e-3 * cotton.stretch_modulus_N_per_m)
        << side << "x" << side;
    // Inside, away from the edges that carry the pull, nothing moves: the strain is uniform.
    const int middle = (side / 2) * side + side / 2;
    EXPECT_LT(forces.col(middle).norm(), 1e-6 * cotton.stretch_modulus_N_per_m * kStrain * spacing_m + 1e-15);
  }
}

TEST(MaterialMapping, SimpleShearGivesTheShearModulus) {
  const MaterialOptions denim = preset("denim");
  constexpr double kShear = 1e-5;  // rad
  for (const int side : {10, 40}) {
    Simulation simulation(sheet(denim, side));
    Eigen::Matrix3Xd sheared = simulation.grid().rest_positions_m;
    sheared.row(1) += kShear * simulation.grid().rest_positions_m.row(0);  // y += gamma x
    const Eigen::Matrix3Xd forces = elasticForces(simulation, sheared);
    // The diagonals run between rows: rows - 1 of them carry the shear, over the width (rows - 1) h.
    const Eigen::Vector3d traction = tractionAcross(forces, side, side, side / 2, 0.5 / (side - 1)) * side / (side - 1);
    EXPECT_NEAR(traction.y() / kShear, denim.shear_modulus_N_per_m, 1e-3 * denim.shear_modulus_N_per_m) << side;
  }
}

TEST(MaterialMapping, MassFollowsTheAreaAndDampingIsARetardationTime) {
  const MaterialOptions wool = preset("wool");
  SceneOptions scene = sheet(wool, 17);
  scene.width_m = 0.8;
  scene.height_m = 0.6;
  Simulation simulation(scene);
  EXPECT_NEAR(simulation.massPerParticle_kg().sum(), wool.areal_density_kg_per_m2 * 0.48, 1e-12);
  // Corner, edge and interior particles carry a quarter, half and whole cell.
  const double cell_kg = wool.areal_density_kg_per_m2 * 0.8 / 16 * 0.6 / 16;
  EXPECT_NEAR(simulation.massPerParticle_kg()[0], 0.25 * cell_kg, 1e-15);
  EXPECT_NEAR(simulation.massPerParticle_kg()[1], 0.5 * cell_kg, 1e-15);
  EXPECT_NEAR(simulation.massPerParticle_kg()[17 + 1], cell_kg, 1e-15);
  for (const SpringOptions& spring : simulation.options().springs) {
    EXPECT_DOUBLE_EQ(spring.damping_N_s_per_m, wool.damping_s * spring.stiffness_N_per_m);
  }
}

TEST(MaterialMapping, BendSpringsMatchTheRigidityAtTheBendingLength) {
  // A sheet bent into a cylinder of curvature k: the bend springs' moment (2/9) k_b h^4 k^3 per width
  // equals B k at k = 1 / bending length, whatever the spacing.
  const MaterialOptions silk = preset("silk");
  for (const int side : {11, 41}) {
    const MaterialConstants constants = materialConstants(silk, BendModel::kSprings, side, side, 0.5, 0.5, 9.81);
    const double h = 0.5 / (side - 1);
    const double k = constants.reference_curvature_per_m;
    const double moment = 2.0 / 9.0 * constants.springs[2].stiffness_N_per_m * std::pow(h, 4) * k * k * k;
    EXPECT_NEAR(moment, silk.bending_rigidity_N_m * k, 1e-9 * silk.bending_rigidity_N_m * k);
    EXPECT_NEAR(constants.bending_length_m, std::cbrt(silk.bending_rigidity_N_m / (silk.areal_density_kg_per_m2 * 9.81)),
                1e-15);
  }
  // The curvature model has no bend springs.
  EXPECT_FALSE(materialConstants(silk, BendModel::kCurvature, 11, 11, 0.5, 0.5, 9.81).springs[2].enabled);
}

/// Positions of the flat sheet rolled onto a cylinder of radius R about an axis along y.
Eigen::Matrix3Xd rolled(const Eigen::Matrix3Xd& flat, double radius_m) {
  Eigen::Matrix3Xd out = flat;
  for (Eigen::Index p = 0; p < flat.cols(); ++p) {
    const double angle = flat(0, p) / radius_m;
    out(0, p) = radius_m * std::sin(angle);
    out(2, p) = radius_m * (1.0 - std::cos(angle));
  }
  return out;
}

TEST(CurvatureBending, EnergyOfACylinderIsHalfBKappaSquaredPerArea) {
  const MaterialOptions denim = preset("denim");
  constexpr double kRadius_m = 0.3;
  double previous_error = 1.0;
  for (const int side : {11, 21, 41}) {
    Simulation simulation(sheet(denim, side, BendModel::kCurvature));
    const CurvatureBending& term = simulation.forceModel().curvatureBending();
    ASSERT_FALSE(term.empty());
    const double energy = term.energy_J(rolled(simulation.grid().rest_positions_m, kRadius_m));
    // The columns at the two ends have no second difference along u: the bent area is (W - h) x H.
    const double h = 0.5 / (side - 1);
    const double expected = 0.5 * denim.bending_rigidity_N_m / (kRadius_m * kRadius_m) * (0.5 - h) * 0.5;
    const double error = std::abs(energy / expected - 1.0);
    EXPECT_LT(error, 0.01) << side;
    EXPECT_LT(error, previous_error + 1e-12) << side;
    previous_error = error;
  }
}

TEST(CurvatureBending, FlatAndRigidlyMovedSheetsFeelNoForceAndForcesAreTheEnergysGradient) {
  const MaterialOptions cotton = preset("cotton");
  Simulation simulation(sheet(cotton, 9, BendModel::kCurvature));
  const CurvatureBending& term = simulation.forceModel().curvatureBending();
  const Eigen::Matrix3Xd& rest = simulation.grid().rest_positions_m;
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  const Eigen::Matrix3Xd moved = (rotation * rest).colwise() + Eigen::Vector3d(0.3, -1.0, 2.0);
  Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, rest.cols());
  term.addForces(moved, Eigen::Matrix3Xd::Zero(3, rest.cols()), forces);
  const double scale = cotton.bending_rigidity_N_m / std::pow(0.5 / 8, 2);
  EXPECT_LT(forces.cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_LT(term.energy_J(moved), 1e-12 * scale * 0.25);
  // Gradient: a random bend, central differences of the energy.
  Eigen::Matrix3Xd bent = rest + 0.01 * Eigen::Matrix3Xd::Random(3, rest.cols());
  forces.setZero();
  term.addForces(bent, Eigen::Matrix3Xd::Zero(3, rest.cols()), forces);
  constexpr double kStep_m = 1e-6;
  for (const Eigen::Index p : {Eigen::Index(0), Eigen::Index(13), Eigen::Index(40)}) {
    for (int axis = 0; axis < 3; ++axis) {
      Eigen::Matrix3Xd plus = bent, minus = bent;
      plus(axis, p) += kStep_m;
      minus(axis, p) -= kStep_m;
      const double gradient = (term.energy_J(plus) - term.energy_J(minus)) / (2.0 * kStep_m);
      EXPECT_NEAR(forces(axis, p), -gradient, 1e-6 * std::abs(gradient) + 1e-10) << p << " " << axis;
    }
  }
  // Its Hessian is symmetric (the implicit solver's CG needs it).
  const Eigen::MatrixXd q = term.hessian();
  EXPECT_LT((q - q.transpose()).cwiseAbs().maxCoeff(), 1e-12 * q.cwiseAbs().maxCoeff());
}

TEST(CurvatureBending, TheImplicitSystemMatrixHoldsIt) {
  // The multigrid's assembled matrix and the matrix-free product agree with the term switched on.
  SceneOptions scene = sheet(preset("denim"), 12, BendModel::kCurvature);
  scene.gravity_m_per_s2 = Eigen::Vector3d(0.0, 0.0, -9.81);
  Simulation simulation(scene);
  ClothForceModel& model = simulation.forceModel();
  const Eigen::Matrix3Xd x = simulation.grid().rest_positions_m + 0.01 * Eigen::Matrix3Xd::Random(3, 144);
  model.linearize(x, Eigen::Matrix3Xd::Zero(3, 144), 0.0);
  GridBlockMatrix matrix;
  ASSERT_TRUE(model.systemGridMatrix(0.02, matrix));
  const Eigen::Matrix3Xd w = Eigen::Matrix3Xd::Random(3, 144);
  Eigen::Matrix3Xd free_product, assembled;
  model.systemProduct(0.02, w, free_product);
  matrix.multiply(w, assembled, 1);
  EXPECT_LT((free_product - assembled).cwiseAbs().maxCoeff(), 1e-9 * free_product.cwiseAbs().maxCoeff());
}

double elasticaDropError(BendModel model, int cols, const MaterialOptions& material, double overhang_m) {
  const ElasticaSolution exact =
      solveHeavyCantilever(material.bending_rigidity_N_m, material.areal_density_kg_per_m2 * 9.81, overhang_m);
  const CantileverMeasurement measured = runCantilever(cantileverScene(material, model, overhang_m, cols), 1000);
  EXPECT_TRUE(measured.settled) << cols;
  return measured.tip_drop_m / exact.tip_drop_m - 1.0;
}

double standardOverhang(const MaterialOptions& material) {
  return overhangForChordAngle(material.bending_rigidity_N_m, material.areal_density_kg_per_m2 * 9.81,
                               kCantileverInclineAngle_rad);
}

TEST(Cantilever, TheElasticaSolverMatchesTheSmallDeflectionLimitAndTheStandardsBendingLength) {
  // A stiff strip barely bends: the drop is the linear beam's w l^4 / (8 B).
  const double b = 1.0, w = 1.0, l = 0.05;
  EXPECT_NEAR(solveHeavyCantilever(b, w, l).tip_drop_m, w * std::pow(l, 4) / (8.0 * b), 1e-6 * w * std::pow(l, 4) / 8.0);
  // ASTM D1388: at 41.5 degrees the overhang is close to twice the bending length (B = w c^3); Peirce's
  // c = l (cos(theta / 2) / (8 tan theta))^(1/3) is the standard's approximation of the elastica.
  const double overhang = overhangForChordAngle(b, w, kCantileverInclineAngle_rad);
  const double theta = kCantileverInclineAngle_rad;
  EXPECT_NEAR(overhang / 2.0, std::cbrt(b / w), 0.03 * std::cbrt(b / w));
  EXPECT_NEAR(overhang * std::cbrt(std::cos(theta / 2.0) / (8.0 * std::tan(theta))), std::cbrt(b / w), 0.02);
}

TEST(Cantilever, CurvatureBendingConvergesToTheHeavyElasticaAtSecondOrder) {
  for (const char* name : {"cotton", "denim"}) {
    const MaterialOptions material = preset(name);
    const double overhang_m = standardOverhang(material);
    const double coarse = elasticaDropError(BendModel::kCurvature, 11, material, overhang_m);
    const double fine = elasticaDropError(BendModel::kCurvature, 21, material, overhang_m);
    std::printf("%s cantilever drop error, curvature: 11 columns %+.5f, 21 columns %+.5f\n", name, coarse, fine);
    EXPECT_LT(std::abs(fine), 0.003) << name;  // the issue asks for 3 % at the finest grid
    EXPECT_GT(std::abs(coarse) / std::abs(fine), 3.0) << name << ": halving the spacing should quarter the error";
  }
}

TEST(Cantilever, BendSpringsMissTheElasticaByMoreThanCurvatureBending) {
  // The paper's trade, measured: bend springs resist a bend as its cube, matched to B at the bending
  // length, so the strip (whose curvature runs from about 1.5 / c at the clamp to 0 at the tip) droops
  // more than the elastica; the curvature term does not. doc/VALIDATION.md has the full table.
  const MaterialOptions denim = preset("denim");
  const double overhang_m = standardOverhang(denim);
  const double springs = elasticaDropError(BendModel::kSprings, 11, denim, overhang_m);
  const double curvature = elasticaDropError(BendModel::kCurvature, 11, denim, overhang_m);
  std::printf("denim cantilever drop error at 11 columns: springs %+.4f, curvature %+.5f\n", springs, curvature);
  EXPECT_GT(springs, 0.05);
  EXPECT_LT(springs, 0.5);
  EXPECT_GT(std::abs(springs), 10.0 * std::abs(curvature));
}

TEST(MaterialValidation, BendSpringsTooFineForTheFabricAreRefusedByName) {
  SceneOptions scene = cantileverScene(preset("denim"), BendModel::kSprings, 0.06, 41);
  const std::vector<std::string> problems = validateSceneOptions(scene);
  ASSERT_FALSE(problems.empty());
  EXPECT_NE(problems.front().find("bend_model = springs"), std::string::npos) << problems.front();
  scene.bend_model = BendModel::kCurvature;
  EXPECT_TRUE(validateSceneOptions(scene).empty());
  scene.has_material = false;
  EXPECT_NE(validateSceneOptions(scene).front().find("bend_model = curvature: needs a material"), std::string::npos);
  MaterialOptions bad = preset("silk");
  bad.shear_modulus_N_per_m = 2.0 * bad.stretch_modulus_N_per_m;
  bad.areal_density_kg_per_m2 = -1.0;
  const std::vector<std::string> material_problems = validateMaterial(bad);
  ASSERT_EQ(material_problems.size(), 2u);
  EXPECT_NE(material_problems[0].find("material.areal_density = -1"), std::string::npos);
  EXPECT_NE(material_problems[1].find("material.shear_modulus"), std::string::npos);
}

/// applySceneYaml of `text` over the defaults: the errors (empty when it was accepted).
std::vector<std::string> parse(const std::string& text, SceneOptions* options) {
  std::vector<std::string> errors;
  applySceneYaml(YAML::Load(text), "test", options, &errors);
  if (errors.empty()) {
    for (const std::string& problem : validateSceneOptions(*options)) errors.push_back(problem);
  }
  return errors;
}

TEST(MaterialKey, APresetNameABlockOrAPresetWithOverrides) {
  SceneOptions by_name;
  ASSERT_TRUE(parse("material: wool", &by_name).empty());
  EXPECT_TRUE(by_name.has_material);
  EXPECT_EQ(by_name.material.preset, "wool");
  SceneOptions block;
  ASSERT_TRUE(parse("{material: {areal_density: 0.2, stretch_modulus: 250.0, shear_modulus: 20.0, "
                    "bending_rigidity: 2.0e-5}, bend_model: curvature}",
                    &block)
                  .empty());
  EXPECT_EQ(block.material.areal_density_kg_per_m2, 0.2);
  EXPECT_EQ(block.material.damping_s, kDefaultMaterialDamping_s);
  EXPECT_EQ(block.bend_model, BendModel::kCurvature);
  SceneOptions heavier;
  ASSERT_TRUE(parse("material: {preset: denim, areal_density: 0.5}", &heavier).empty());
  EXPECT_EQ(heavier.material.areal_density_kg_per_m2, 0.5);
  EXPECT_EQ(heavier.material.bending_rigidity_N_m, preset("denim").bending_rigidity_N_m);
  // The cloth's mass follows from its area.
  EXPECT_DOUBLE_EQ(resolveMaterial(heavier).mass_kg, 0.5 * heavier.width_m * heavier.height_m);
}

TEST(MaterialKey, MistakesAreNamed) {
  const auto first_error = [](const std::string& text) {
    SceneOptions options;
    const std::vector<std::string> errors = parse(text, &options);
    return errors.empty() ? std::string() : errors.front();
  };
  EXPECT_NE(first_error("material: velvet").find("cotton, denim, wool, polyester, silk"), std::string::npos);
  EXPECT_NE(first_error("material: {areal_density: 0.2}").find("missing stretch_modulus, shear_modulus, bending_rigidity"),
            std::string::npos);
  EXPECT_NE(first_error("material: {preset: cotton, thickness: 1}").find("'thickness'"), std::string::npos);
  EXPECT_NE(first_error("bend_model: wavy").find("springs or curvature"), std::string::npos);
  EXPECT_NE(first_error("material: {preset: cotton, damping: -1}").find("material.damping = -1"), std::string::npos);
  // Both a material and the constants it sets: refused, naming them.
  const std::string both = first_error("{material: cotton, mass: 0.3, bend_stiffness: 10}");
  EXPECT_NE(both.find("material and bend_stiffness, mass given together"), std::string::npos) << both;
  // Also when a later source (the node's parameters) sets a constant over a scene file's material.
  SceneOptions from_file;
  ASSERT_TRUE(parse("material: cotton", &from_file).empty());
  EXPECT_FALSE(parse("structural_stiffness: 500", &from_file).empty());
}

TEST(MaterialScenes, RetuneRefusesTheConstantsTheMaterialSetsAndKeepsTheRest) {
  SceneOptions scene = sheet(preset("polyester"), 8);
  Simulation simulation(scene);
  SceneOptions tuned = simulation.options();
  tuned.air_damping_N_s_per_m = 0.01;
  std::string error;
  EXPECT_TRUE(simulation.retune(tuned, &error)) << error;
  tuned.springs[0].stiffness_N_per_m = 10.0;
  EXPECT_FALSE(simulation.retune(tuned, &error));
  EXPECT_NE(error.find("structural springs: set by the material"), std::string::npos) << error;
}

TEST(MaterialScenes, AirDampingAndThePapersWindActPerArea) {
  // The same material cloth at 10x10 and 40x40: the total air damping and paper wind force are the same,
  // and on the paper's 20x20 1 m square they are the per-particle and per-triangle values as given.
  double totals[2][2];
  const int sides[2] = {10, 40};
  for (int i = 0; i < 2; ++i) {
    SceneOptions scene = sheet(preset("cotton"), sides[i]);
    scene.wind_enabled = true;
    scene.wind.velocity_m_per_s = Eigen::Vector3d(0.0, 0.0, 2.0);
    Simulation simulation(scene);
    const Eigen::Index n = simulation.grid().particleCount();
    Eigen::Matrix3Xd forces = Eigen::Matrix3Xd::Zero(3, n);
    const Eigen::Matrix3Xd& rest = simulation.grid().rest_positions_m;
    simulation.forceModel().forces(rest, Eigen::Matrix3Xd::Zero(3, n), 0.0, forces);
    totals[i][0] = forces.row(2).sum();
    forces.setZero();
    Eigen::Matrix3Xd moving = Eigen::Matrix3Xd::Zero(3, n);
    moving.row(0).setConstant(1.0);
    SceneOptions calm = scene;
    calm.wind_enabled = false;
    Simulation still(calm);
    still.forceModel().forces(rest, moving, 0.0, forces);
    totals[i][1] = forces.row(0).sum();
  }
  EXPECT_NEAR(totals[0][0], totals[1][0], 1e-9 * std::abs(totals[0][0]));
  EXPECT_NEAR(totals[0][1], totals[1][1], 1e-9 * std::abs(totals[0][1]));
  SceneOptions paper_grid;
  paper_grid.has_material = true;
  paper_grid.material = preset("cotton");
  EXPECT_DOUBLE_EQ(airDampingPerParticle_N_s_per_m(paper_grid), paper_grid.air_damping_N_s_per_m);
  EXPECT_DOUBLE_EQ(paperWindCoefficientPerTriangle_N_s_per_m(paper_grid), paper_grid.wind.paper_coefficient_N_s_per_m);
}

// compression_model: buckling (Choi and Ko 2002): a compressed structural or shear spring pushes back at
// most the Euler load of the strip of fabric it stands for.

TEST(BucklingSprings, ACompressedSpringPushesBackAtMostItsCapAndItsEnergyIsTheForcesIntegral) {
  // One spring 0.1 m long, 1000 N/m, capped at 2 N: the cap is reached at 2 mm of compression.
  SpringSet spring;
  spring.first = {0};
  spring.second = {1};
  spring.rest_length_m = {0.1};
  SpringOptions options{true, 1000.0, 0.0};
  options.buckling_N_m3 = 2.0 * 0.1 * 0.1 * 0.1;
  EXPECT_DOUBLE_EQ(springCompressionCap_N(options, 0.1), 2.0);
  const auto pushOnFirst = [&](double length_m) {
    Eigen::Matrix3Xd x(3, 2), v = Eigen::Matrix3Xd::Zero(3, 2), f = Eigen::Matrix3Xd::Zero(3, 2);
    x << 0.0, length_m, 0.0, 0.0, 0.0, 0.0;
    accumulateSpringForces(spring, options, x, v, f);
    return f(0, 0);  // along +x: pulled towards the second end
  };
  const auto energy = [&](double length_m) {
    Eigen::Matrix3Xd x(3, 2);
    x << 0.0, length_m, 0.0, 0.0, 0.0, 0.0;
    return springPotentialEnergy(spring, options, x);
  };
  EXPECT_NEAR(pushOnFirst(0.105), 5.0, 1e-12);   // in tension: linear, whatever the cap
  EXPECT_NEAR(pushOnFirst(0.099), -1.0, 1e-12);  // compressed below the cap: linear
  EXPECT_NEAR(pushOnFirst(0.095), -2.0, 1e-12);  // past it: the cap
  EXPECT_NEAR(pushOnFirst(0.050), -2.0, 1e-12);
  // The energy is the force's integral: its slope is the force on both sides of the cap, and it is
  // continuous where the cap is reached (2 mJ there).
  for (const double length_m : {0.105, 0.099, 0.095, 0.050}) {
    const double step_m = 1e-7;
    const double slope_N = (energy(length_m + step_m) - energy(length_m - step_m)) / (2.0 * step_m);
    EXPECT_NEAR(slope_N, pushOnFirst(length_m), 1e-6) << length_m;
  }
  EXPECT_NEAR(energy(0.098), 0.002, 1e-15);
  EXPECT_NEAR(energy(0.097) - energy(0.098), 2.0 * 0.001, 1e-12);
  // Without a buckling load a spring is linear however far it is compressed.
  options.buckling_N_m3 = 0.0;
  EXPECT_NEAR(pushOnFirst(0.050), -50.0, 1e-12);
}

TEST(BucklingSprings, EachSpringIsCappedAtTheEulerLoadOfItsStripOfFabric) {
  // A 0.6 x 0.4 m sheet on 7 x 9 particles: du = 0.05, dv = 0.1 m. A row spring (L = du) stands for a
  // strip dv wide, a column spring for one du wide, each diagonal for half a cell's area over its length.
  SceneOptions scene = sheet(preset("denim"), 7);
  scene.cols = 13;
  scene.width_m = 0.6;
  scene.height_m = 0.6;
  scene.compression_model = CompressionModel::kBuckling;
  const SceneOptions resolved = resolveMaterial(scene);
  const double B = preset("denim").bending_rigidity_N_m;
  const double pi2 = 9.8696044010893586;
  const double du = 0.05, dv = 0.1, diagonal = std::hypot(du, dv);
  const SpringOptions& structural = resolved.springs[static_cast<int>(SpringKind::kStructural)];
  const SpringOptions& shear = resolved.springs[static_cast<int>(SpringKind::kShear)];
  EXPECT_NEAR(springCompressionCap_N(structural, du), pi2 * B * dv / (du * du), 1e-12);
  EXPECT_NEAR(springCompressionCap_N(structural, dv), pi2 * B * du / (dv * dv), 1e-12);
  EXPECT_NEAR(springCompressionCap_N(shear, diagonal), pi2 * B * (du * dv / (2.0 * diagonal)) / (diagonal * diagonal),
              1e-12);
  // The bend springs (off with the curvature term, and the bending itself with springs) are never capped,
  // and the linear model caps nothing.
  EXPECT_EQ(resolved.springs[static_cast<int>(SpringKind::kBend)].buckling_N_m3, 0.0);
  scene.compression_model = CompressionModel::kLinear;
  EXPECT_EQ(resolveMaterial(scene).springs[static_cast<int>(SpringKind::kStructural)].buckling_N_m3, 0.0);
}

TEST(BucklingSprings, TheGridKernelsCapAsTheSpringsDoAndACappedSpringHasNoStiffness) {
  SceneOptions scene = sheet(preset("cotton"), 9, BendModel::kCurvature);
  scene.compression_model = CompressionModel::kBuckling;
  Simulation simulation(scene);
  const Eigen::Matrix3Xd& rest = simulation.grid().rest_positions_m;
  const Eigen::Matrix3Xd zero = Eigen::Matrix3Xd::Zero(3, rest.cols());
  // Squeezed to 90 %: every structural and shear spring past its cap (here the structural springs reach
  // it at a strain of 2.5e-6, the shear springs at 6e-5). A uniform squeeze is an affine map, on which the curvature term exerts
  // nothing, so the forces are the springs' alone.
  const Eigen::Matrix3Xd squeezed = 0.9 * rest;
  const Eigen::Matrix3Xd grid_forces = elasticForces(simulation, squeezed);
  Eigen::Matrix3Xd reference = Eigen::Matrix3Xd::Zero(3, rest.cols());
  for (int k : {static_cast<int>(SpringKind::kStructural), static_cast<int>(SpringKind::kShear)}) {
    accumulateSpringForces(simulation.grid().springs[k], simulation.options().springs[k], squeezed, zero, reference);
  }
  ASSERT_GT(reference.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((grid_forces - reference).cwiseAbs().maxCoeff(), 1e-12 * reference.cwiseAbs().maxCoeff());
  // At the cap the pushes are constant: squeezing further changes no force...
  EXPECT_LT((elasticForces(simulation, 0.85 * rest) - grid_forces).cwiseAbs().maxCoeff(),
            1e-12 * grid_forces.cwiseAbs().maxCoeff());
  // ...and the linearisation has no stiffness along or across a capped spring: its differential for any
  // affine change of the positions (which the curvature term does not feel either) is zero, to the
  // curvature term's rounding. The same sheet squeezed by a strain of 1e-7, under the caps, is as stiff
  // as its linear springs.
  ClothForceModel& model = simulation.forceModel();
  const Eigen::Matrix3d map = Eigen::Matrix3d::Random();
  const Eigen::Matrix3Xd affine = map * rest;
  Eigen::Matrix3Xd differential;
  model.linearize(squeezed, zero, 0.0);
  model.forceDifferential(affine, zero, differential);
  const double capped_N = differential.cwiseAbs().maxCoeff();
  model.linearize((1.0 - 1e-7) * rest, zero, 0.0);
  model.forceDifferential(affine, zero, differential);
  const double linear_N = differential.cwiseAbs().maxCoeff();
  EXPECT_GT(linear_N, 1.0);
  EXPECT_LT(capped_N, 1e-12 * linear_N);
}

TEST(BucklingSprings, TheDrapeSagsAlikeAt20And40ParticlesPerSide) {
  // The `drape` scene (cotton, 1 m square on two hooks 0.6 m apart) after 20 s (its corners reach the
  // hooks at 4 s): its top edge's middle below the hooks. The 20 x 20 grid's 5 cm cells are wider than
  // the folds cotton makes: with linear springs it cannot fold there without compressing its stiff
  // membrane, and hangs 6 cm (17 %) shallower than 80 x 80 (doc/VALIDATION.md); with the buckling cap
  // 20 x 20 and 40 x 40 sag alike, within the 2 % the issue asks (measured: 0.9 %).
  constexpr int kTwentySecondsOfFrames = 1000;
  const auto sag_m = [](int side) {
    SceneOptions options = test::loadBuiltinScene("drape");
    options.rows = options.cols = side;
    options.compression_model = CompressionModel::kBuckling;
    Simulation simulation(options);
    for (int frame = 0; frame < kTwentySecondsOfFrames; ++frame) simulation.advanceFrame();
    const ClothGrid& grid = simulation.grid();
    const Eigen::Matrix3Xd& x = simulation.state().positions_m;
    const double middle_z = 0.5 * (x(2, grid.index(0, (side - 1) / 2)) + x(2, grid.index(0, side / 2)));
    return options.pin_positions_m.front().z() - middle_z;
  };
  const double coarse_m = sag_m(20);
  const double fine_m = sag_m(40);
  EXPECT_GT(fine_m, 0.3);
  EXPECT_NEAR(coarse_m, fine_m, 0.02 * fine_m);
}

TEST(BucklingSprings, TheKeyIsNamedAndNeedsAMaterial) {
  SceneOptions options;
  ASSERT_TRUE(parse("{material: silk, compression_model: buckling}", &options).empty());
  EXPECT_EQ(options.compression_model, CompressionModel::kBuckling);
  EXPECT_NE(parse("compression_model: soft", &options).front().find("linear or buckling"), std::string::npos);
  SceneOptions paper;
  paper.compression_model = CompressionModel::kBuckling;
  const std::vector<std::string> problems = validateSceneOptions(paper);
  ASSERT_FALSE(problems.empty());
  EXPECT_NE(problems.front().find("compression_model = buckling: needs a material"), std::string::npos);
}

}  // namespace
}  // namespace cloth_sim::core
