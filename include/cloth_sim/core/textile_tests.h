// Textile tests as simulations and their exact answers (issue 17, doc/VALIDATION.md): the cantilever
// bending test (ASTM D1388) against the heavy elastica, and the scenes and measurements the validation
// and its tests share. ROS-free; cloth_bench --validate runs them at full size, the gtests at small size.
#pragma once

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/material.h"
#include "cloth_sim/core/options.h"

#include <Eigen/Core>

#include <vector>

namespace cloth_sim::core {

/// ASTM D1388's strip: 25 mm wide.
inline constexpr double kCantileverStripWidth_m = 0.025;
/// ASTM D1388's incline, rad (41.5 degrees): the overhang at which the tip touches it is twice the
/// bending length.
inline constexpr double kCantileverInclineAngle_rad = 41.5 * kPi / 180.0;

/// The heavy elastica: an inextensible strip of length l, clamped horizontally, bending under its own
/// weight w per area (N/m^2) with rigidity B (N m): B theta'' = -w (l - s) cos(theta), theta(0) = 0,
/// theta'(l) = 0, solved by shooting on theta'(0).
struct ElasticaSolution {
  double tip_drop_m = 0.0;    ///< how far the free end lies below the clamp
  double tip_reach_m = 0.0;   ///< how far it lies beyond the clamp, horizontally
  double clamp_curvature_per_m = 0.0;
  std::vector<Eigen::Vector2d> profile_m;  ///< (reach, drop) along the strip, clamp first
};
ElasticaSolution solveHeavyCantilever(double rigidity_N_m, double weight_N_per_m2, double length_m);

/// The overhang whose tip chord (drop over reach) makes angle_rad with the horizontal.
double overhangForChordAngle(double rigidity_N_m, double weight_N_per_m2, double angle_rad);

/// A strip kCantileverStripWidth_m wide with `overhang_m` free beyond a clamp, horizontal along +x at
/// z = 0, gravity -z: cols particles along the free part (one more cell is in the clamp: the first two
/// columns are pinned, which holds the clamp's slope), and rows across it for cells as square as
/// possible (at least 3). Implicit Euler with one-second frames, which bring it to rest in a few.
SceneOptions cantileverScene(const MaterialOptions& material, BendModel bend_model, double overhang_m, int cols);

struct CantileverMeasurement {
  double tip_drop_m = 0.0;   ///< the free end's mean drop below the clamp
  double tip_reach_m = 0.0;  ///< its mean reach beyond the clamp
  int frames = 0;            ///< frames simulated
  bool settled = false;      ///< the tip moved less than the settling tolerance in the last frame
  std::vector<Eigen::Vector2d> profile_m;  ///< (reach, drop) of the middle row's particles, clamp side first
};
/// Runs a cantileverScene until its tip settles (at most max_frames).
CantileverMeasurement runCantilever(const SceneOptions& scene, int max_frames);

/// BS 5058 (Cusick): a disc of fabric 30 cm across clamped on a support disc 18 cm across, horizontal.
inline constexpr double kCusickSpecimenDiameter_m = 0.30;
inline constexpr double kCusickSupportDiameter_m = 0.18;

/// The Cusick specimen: a side x side grid over the disc's square, its circle as the outline, every
/// particle over the support pinned (the clamp), at z = 1 m with gravity -z, no floor.
SceneOptions cusickScene(const MaterialOptions& material, BendModel bend_model, int side);

struct CusickMeasurement {
  double projected_area_m2 = 0.0;   ///< the draped specimen's shadow from above (S)
  double drape_coefficient = 0.0;   ///< (S - S_support) / (S_specimen - S_support)
  int folds = 0;                    ///< crests of the hem around the support
  int frames = 0;
  double last_second_motion_m = 0.0;  ///< the most any particle moved in the last simulated second
  Eigen::Matrix3Xd positions_m;       ///< at the end
  std::vector<int> triangles;         ///< the specimen's (the grid's kept triangles), for pictures
};
/// Runs a cusickScene for `seconds` and measures it.
CusickMeasurement runCusick(const SceneOptions& scene, double seconds);

/// The area of the union of the triangles' projections on the world xy plane, m^2, counted on a raster
/// of pixel_m squares (each pixel whose centre a projected triangle covers).
double projectedArea_m2(const std::vector<int>& triangles, const Eigen::Matrix3Xd& positions_m, double pixel_m);

/// The folds of a draped disc: the hem (the particles inside the outline next to one outside) as its
/// distance from centre_m in the xy plane against the angle round it, and the wave number (2 to 16) whose
/// amplitude grew most over the flat specimen's; 0 when none grew by a tenth of a grid spacing.
int countFolds(const ClothGrid& grid, const Eigen::Matrix3Xd& positions_m, const Eigen::Vector2d& centre_m);

}  // namespace cloth_sim::core
