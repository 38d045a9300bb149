// Fabric in physical units (issue 17): a material's areal density and membrane and bending stiffness,
// mapped to the grid's spring constants and masses for whatever spacing the scene has, so that the same
// material at 20x20, 40x40 and 80x80 is the same cloth. doc/PHYSICS.md ("Materials") derives every
// formula here; doc/VALIDATION.md checks them against textile tests.
#pragma once

#include "cloth_sim/core/forces.h"
#include "cloth_sim/core/grid.h"

#include <Eigen/Core>

#include <array>
#include <string>
#include <vector>

namespace cloth_sim::core {

/// A woven fabric as a thin sheet (per unit area or width, as textile tests report it).
struct MaterialOptions {
  /// The preset this material came from ("" for a block written by hand), kept for messages and files.
  std::string preset;
  double areal_density_kg_per_m2 = 0.0;
  /// Uniaxial tensile stiffness along the threads, N/m: Young's modulus x thickness, the slope of force
  /// per width against strain in a strip test.
  double stretch_modulus_N_per_m = 0.0;
  /// In-plane shear stiffness, N/m (shear force per width per radian of shear angle).
  double shear_modulus_N_per_m = 0.0;
  /// Bending rigidity, N m (bending moment per width per unit curvature).
  double bending_rigidity_N_m = 0.0;
  /// Kelvin-Voigt retardation time, s: the fabric's internal friction adds damping x the rate of every
  /// elastic force (each spring's Kd = damping x Ks, and the curvature term's likewise), so a mode of
  /// angular frequency w has the damping ratio damping x w / 2 at every resolution.
  double damping_s = 0.0;
};

/// How bending is modelled (scene key `bend_model`).
enum class BendModel {
  /// The paper's simplification: springs two particles apart (their stretch grows with the square of
  /// the bend angle, so a flat sheet resists small bends hardly at all).
  kSprings,
  /// A curvature energy on the grid, E = B/2 sum_i A_i |(Laplacian x)_i|^2 (Bergou et al. 2006's
  /// quadratic bending on this grid): linear in the bend, its Hessian constant. Needs a material.
  kCurvature,
};

const char* bendModelName(BendModel model);

/// How a compressed structural or shear spring pushes back (scene key `compression_model`).
enum class CompressionModel {
  /// As it pulls in tension: Ks (L - l).
  kLinear,
  /// At most the Euler load of the strip of fabric it stands for, pi^2 B w / L^2 (w the strip's width,
  /// L the spring's rest length): a real fabric buckles into folds under far less compression than its
  /// stretch modulus would carry, and a grid whose cells are wider than those folds cannot fold there
  /// (Choi and Ko 2002's post-buckling response). Needs a material (its bending rigidity B).
  kBuckling,
};

const char* compressionModelName(CompressionModel model);
/// "linear" or "buckling"; false for anything else.
bool parseCompressionModelName(const std::string& name, CompressionModel* model);
/// "springs" or "curvature"; false for anything else.
bool parseBendModelName(const std::string& name, BendModel* model);

/// Default retardation time of a material block that gives none, s.
inline constexpr double kDefaultMaterialDamping_s = 1e-3;

/// The built-in fabrics (doc/PHYSICS.md gives each one's sources), in a fixed order.
const std::vector<MaterialOptions>& materialPresets();
/// The preset of that name; false if there is none.
bool findMaterialPreset(const std::string& name, MaterialOptions* material);
/// "cotton, denim, ..." for messages.
std::string materialPresetNames();

/// Standard gravity, m/s^2: sets the bending length of a scene without gravity.
inline constexpr double kStandardGravity_m_per_s2 = 9.80665;

/// The grid constants a material gives for one grid, all derived in doc/PHYSICS.md ("Materials").
struct MaterialConstants {
  /// Indexed by SpringKind. Structural: k = C11 - G - 4 k_bend; shear: k = G; bend: matched to the
  /// curvature energy's moment at reference_curvature (zero and off with the curvature model).
  std::array<SpringOptions, kSpringKindCount> springs{};
  double mass_kg = 0.0;                  ///< areal density x width x height
  double spacing_m = 0.0;                ///< sqrt(du dv): the cells are taken as squares of this side
  double bending_length_m = 0.0;         ///< (B / (rho_A g))^(1/3): the cantilever's bending length
  double reference_curvature_per_m = 0.0;  ///< 1 / bending_length: where the bend springs match B
  /// compression_model: buckling's SpringOptions::buckling_N_m3, N m^3: pi^2 B du dv for the structural
  /// springs (a row spring, L = du, stands for a strip dv wide: pi^2 B dv / du^2) and half that for the
  /// shear springs (two diagonals per cell, each a strip du dv / (2 L) wide).
  double structural_buckling_N_m3 = 0.0;
  double shear_buckling_N_m3 = 0.0;
};

/// The constants `material` gives on a rows x cols grid of width x height m, under gravity of
/// gravity_m_per_s2 (standard gravity if zero), with bend springs or the curvature term.
MaterialConstants materialConstants(const MaterialOptions& material, BendModel bend_model, int rows, int cols,
                                    double width_m, double height_m, double gravity_m_per_s2);

/// Every problem with a material's values, each naming the field (prefixed "material.").
std::vector<std::string> validateMaterial(const MaterialOptions& material);

/// Lumped particle masses for a material grid: each particle carries the area of the cells around it
/// (a quarter cell per cell corner), so edge particles carry half and corners a quarter of an interior
/// one; they sum to total_mass_kg.
Eigen::VectorXd areaLumpedMasses(int rows, int cols, double total_mass_kg);

}  // namespace cloth_sim::core
