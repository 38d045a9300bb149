#include "cloth_sim/core/material.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/enum_names.h"

#include <cmath>
#include <sstream>

namespace cloth_sim::core {

namespace {

/// The ranges a material's values may take: wide around fabric (woven fabrics span about 0.03-0.6 kg/m^2,
/// 1e3-1e5 N/m and 1e-7-1e-3 N m), short of sheet metal (1 mm steel: 2e8 N/m, 20 N m).
constexpr double kMinArealDensity_kg_per_m2 = 1e-3;  ///< 1 g/m^2, below the lightest tissue
constexpr double kMaxArealDensity_kg_per_m2 = 10.0;  ///< heavy canvas and rubber sheet are under 2
constexpr double kMaxStretchModulus_N_per_m = 1e6;
constexpr double kMaxBendingRigidity_N_m = 1.0;
/// Longest retardation time, s: 0.1 s already damps every mode above 20 rad/s critically.
constexpr double kMaxDamping_s = 0.1;

/// The bend springs span two cells: over a bend of curvature k a spring of rest length 2h is shortened by
/// 2h (h k)^2 / 6, so per unit area its energy is k_b h^4 k^4 / 18 and its moment per width (2/9) k_b h^4 k^3
/// (doc/PHYSICS.md). That equals the continuum's B k at the reference curvature when
/// k_b = kBendSpringMomentFactor B / (h^4 k_ref^2).
constexpr double kBendSpringMomentFactor = 4.5;
/// Two bend springs cross every line across their direction per grid row (those starting one and two
/// particles before it), each stretched over 2h: they add 4 k_b to the sheet's tensile stiffness.
constexpr double kBendSpringsInStretch = 4.0;

constexpr EnumNames<BendModel, 2> kBendModelNames{{{BendModel::kSprings, "springs"}, {BendModel::kCurvature, "curvature"}}};
constexpr EnumNames<CompressionModel, 2> kCompressionModelNames{
    {{CompressionModel::kLinear, "linear"}, {CompressionModel::kBuckling, "buckling"}}};

}  // namespace

const char* bendModelName(BendModel model) { return enumName(kBendModelNames, model); }

bool parseBendModelName(const std::string& name, BendModel* model) {
  return parseEnumName(kBendModelNames, name, model);
}

const char* compressionModelName(CompressionModel model) { return enumName(kCompressionModelNames, model); }

bool parseCompressionModelName(const std::string& name, CompressionModel* model) {
  return parseEnumName(kCompressionModelNames, name, model);
}

const std::vector<MaterialOptions>& materialPresets() {
  // Representative low-strain values of each fabric class from the measurement literature cited in
  // doc/PHYSICS.md ("Material presets"), converted to SI: KES-F tensile (secant modulus at small
  // strain), shear (G, gf/(cm deg) x 56.2 = N/m) and bending (B, gf cm^2/cm x 9.81e-5 = N m).
  static const std::vector<MaterialOptions> presets{
      {"cotton", 0.12, 8000.0, 40.0, 8.0e-6, kDefaultMaterialDamping_s},
      {"denim", 0.40, 15000.0, 150.0, 1.0e-4, kDefaultMaterialDamping_s},
      {"wool", 0.25, 6000.0, 40.0, 1.2e-5, kDefaultMaterialDamping_s},
      {"polyester", 0.11, 10000.0, 50.0, 6.0e-6, kDefaultMaterialDamping_s},
      {"silk", 0.05, 5000.0, 20.0, 2.0e-6, kDefaultMaterialDamping_s},
  };
  return presets;
}

bool findMaterialPreset(const std::string& name, MaterialOptions* material) {
  for (const MaterialOptions& preset : materialPresets()) {
    if (preset.preset != name) continue;
    *material = preset;
    return true;
  }
  return false;
}

std::string materialPresetNames() {
  std::string names;
  for (const MaterialOptions& preset : materialPresets()) names += (names.empty() ? "" : ", ") + preset.preset;
  return names;
}

MaterialConstants materialConstants(const MaterialOptions& m, BendModel bend_model, int rows, int cols,
                                    double width_m, double height_m, double gravity_m_per_s2) {
  MaterialConstants constants;
  const double du_m = width_m / (cols - 1);
  const double dv_m = height_m / (rows - 1);
  const double h = std::sqrt(du_m * dv_m);
  constants.spacing_m = h;
  constants.mass_kg = m.areal_density_kg_per_m2 * width_m * height_m;
  const double g = gravity_m_per_s2 > 0.0 ? gravity_m_per_s2 : kStandardGravity_m_per_s2;
  constants.bending_length_m = std::cbrt(m.bending_rigidity_N_m / (m.areal_density_kg_per_m2 * g));
  constants.reference_curvature_per_m = constants.bending_length_m > 0.0 ? 1.0 / constants.bending_length_m : 0.0;

  SpringOptions& bend = constants.springs[static_cast<int>(SpringKind::kBend)];
  if (bend_model == BendModel::kSprings && m.bending_rigidity_N_m > 0.0) {
    const double k_ref = constants.reference_curvature_per_m;
    bend = {true, kBendSpringMomentFactor * m.bending_rigidity_N_m / (h * h * h * h * k_ref * k_ref), 0.0};
  } else {
    bend = {false, 0.0, 0.0};
  }
  // Diagonal springs of stiffness G give the sheet a shear modulus G and add G to C11 and C12 (central
  // springs obey Cauchy's relation C12 = C66); a uniaxial strip test measures C11 - C12^2 / C11, which is
  // the stretch modulus Y when C11 = (Y + sqrt(Y^2 + 4 G^2)) / 2.
  const double Y = m.stretch_modulus_N_per_m;
  const double G = m.shear_modulus_N_per_m;
  const double c11 = 0.5 * (Y + std::sqrt(Y * Y + 4.0 * G * G));
  constants.springs[static_cast<int>(SpringKind::kShear)] = {true, G, 0.0};
  constants.springs[static_cast<int>(SpringKind::kStructural)] = {
      true, c11 - G - kBendSpringsInStretch * bend.stiffness_N_per_m, 0.0};
  for (SpringOptions& spring : constants.springs) spring.damping_N_s_per_m = m.damping_s * spring.stiffness_N_per_m;
  constexpr double kPiSquared = kPi * kPi;
  constants.structural_buckling_N_m3 = kPiSquared * m.bending_rigidity_N_m * du_m * dv_m;
  constants.shear_buckling_N_m3 = 0.5 * constants.structural_buckling_N_m3;
  return constants;
}

std::vector<std::string> validateMaterial(const MaterialOptions& m) {
  std::vector<std::string> problems;
  const auto inRange = [&problems](const std::string& field, double value, double low, double high, bool open_low) {
    if (std::isfinite(value) && (open_low ? value > low : value >= low) && value <= high) return;
    std::ostringstream out;
    out << "material." << field << " = " << value << ": must be in " << (open_low ? "(" : "[") << low << ", " << high
        << "]";
    problems.push_back(out.str());
  };
  inRange("areal_density", m.areal_density_kg_per_m2, kMinArealDensity_kg_per_m2, kMaxArealDensity_kg_per_m2, false);
  inRange("stretch_modulus", m.stretch_modulus_N_per_m, 0.0, kMaxStretchModulus_N_per_m, true);
  // A shear stiffness above the tensile one is no woven fabric, and leaves the structural springs
  // (C11 - G) too weak to carry it.
  const double shear_limit = std::isfinite(m.stretch_modulus_N_per_m) && m.stretch_modulus_N_per_m > 0.0
                                 ? std::min(m.stretch_modulus_N_per_m, kMaxStretchModulus_N_per_m)
                                 : kMaxStretchModulus_N_per_m;
  inRange("shear_modulus", m.shear_modulus_N_per_m, 0.0, shear_limit, false);
  inRange("bending_rigidity", m.bending_rigidity_N_m, 0.0, kMaxBendingRigidity_N_m, false);
  inRange("damping", m.damping_s, 0.0, kMaxDamping_s, false);
  return problems;
}

Eigen::VectorXd areaLumpedMasses(int rows, int cols, double total_mass_kg) {
  Eigen::VectorXd mass(static_cast<Eigen::Index>(rows) * cols);
  const double cell_mass_kg = total_mass_kg / ((rows - 1) * (cols - 1));
  for (int r = 0; r < rows; ++r) {
    const double row_share = (r == 0 || r == rows - 1) ? 0.5 : 1.0;
    for (int c = 0; c < cols; ++c) {
      const double col_share = (c == 0 || c == cols - 1) ? 0.5 : 1.0;
      mass[static_cast<Eigen::Index>(r) * cols + c] = cell_mass_kg * row_share * col_share;
    }
  }
  return mass;
}

}  // namespace cloth_sim::core
