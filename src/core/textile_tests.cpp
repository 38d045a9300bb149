#include "cloth_sim/core/textile_tests.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace cloth_sim::core {

namespace {

/// RK4 steps along the strip for one shot (fourth order: the drop changes by under 1e-10 of the length
/// from 1000 steps to 4000).
constexpr int kShootingSteps = 1000;
/// Bisection halvings on theta'(0) and on the overhang: to 1e-15 of their brackets, far below any
/// tolerance the tests use.
constexpr int kBisections = 50;
/// A tip that moved less than this in a frame has settled, m.
constexpr double kSettledTipMotion_m = 1e-7;
/// The strip's frame rate with the curvature term: implicit Euler with one-second steps damps its bending
/// modes (about 10 rad/s) by 1 / (1 + (w h)^2) ~ 1/100 per step, so it comes to rest in a few steps; where
/// it rests does not depend on the step. Bend springs have no stiffness at all against the first bend of
/// the flat strip, so a one-second step lets it fall freely (the guard rejects it): they bend it at
/// kSpringCantileverFrameRate_hz, slowed to rest by kSpringCantileverAirDamping (per area, as in the
/// paper's cloth).
constexpr double kCantileverFrameRate_hz = OptionLimits::kMinFrameRateHz;
constexpr double kSpringCantileverFrameRate_hz = 20.0;
constexpr double kSpringCantileverAirDamping_N_s_per_m = 0.02;
constexpr int kMinStripRows = 3;
/// Longest overhang searched for a chord angle, in bending lengths (the strip hangs nearly straight down).
constexpr double kLongestOverhangInBendingLengths = 64.0;
/// The Cusick specimen's height above nothing (no floor), m.
constexpr double kCusickHeight_m = 1.0;
/// Shadow raster, m: 0.5 mm pixels resolve the area of a 30 cm disc to about 0.1 %.
constexpr double kCusickPixel_m = 5e-4;
/// Fold counting: the hem's distance from the centre in 1-degree bins; folds between kFewestFolds and
/// kMostFolds (published drapes have 3 to 12); a wave that grew by under kFoldGrowthSpacings grid
/// spacings over the flat specimen's is none.
constexpr int kFoldBins = 360;
constexpr int kFewestFolds = 2;
constexpr int kMostFolds = 16;
constexpr double kFoldGrowthSpacings = 0.1;

struct Shot {
  double end_curvature = 0.0;  ///< theta'(l): zero for the right initial curvature
  ElasticaSolution solution;
};

/// Integrates theta'' = -(w / B)(l - s) cos(theta) from the clamp with theta'(0) = k0.
Shot shoot(double load_per_rigidity, double length_m, double k0, bool keep_profile) {
  const double ds = length_m / kShootingSteps;
  double s = 0.0, theta = 0.0, kappa = k0, reach = 0.0, drop = 0.0;
  Shot shot;
  if (keep_profile) shot.solution.profile_m.emplace_back(0.0, 0.0);
  // State (theta, kappa, reach, drop); derivatives (kappa, -q (l - s) cos theta, cos theta, sin theta).
  const auto derivative = [&](double at_s, const Eigen::Vector4d& y) {
    return Eigen::Vector4d(y[1], -load_per_rigidity * (length_m - at_s) * std::cos(y[0]), std::cos(y[0]),
                           std::sin(y[0]));
  };
  for (int i = 0; i < kShootingSteps; ++i) {
    const Eigen::Vector4d y(theta, kappa, reach, drop);
    const Eigen::Vector4d k1 = derivative(s, y);
    const Eigen::Vector4d k2 = derivative(s + 0.5 * ds, y + 0.5 * ds * k1);
    const Eigen::Vector4d k3 = derivative(s + 0.5 * ds, y + 0.5 * ds * k2);
    const Eigen::Vector4d k4 = derivative(s + ds, y + ds * k3);
    const Eigen::Vector4d next = y + ds / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    theta = next[0];
    kappa = next[1];
    reach = next[2];
    drop = next[3];
    s += ds;
    if (keep_profile) shot.solution.profile_m.emplace_back(reach, drop);
  }
  shot.end_curvature = kappa;
  shot.solution.tip_drop_m = drop;
  shot.solution.tip_reach_m = reach;
  shot.solution.clamp_curvature_per_m = k0;
  return shot;
}

}  // namespace

ElasticaSolution solveHeavyCantilever(double rigidity_N_m, double weight_N_per_m2, double length_m) {
  const double q = weight_N_per_m2 / rigidity_N_m;
  // theta'(l) grows with theta'(0): 0 when the strip is straight gives theta'(l) < 0 (it bends down
  // anyway), the clamp moment of a straight horizontal strip, q l^2 / 2, gives theta'(l) > 0.
  double low = 0.0;
  double high = q * length_m * length_m;
  for (int i = 0; i < kBisections; ++i) {
    const double mid = 0.5 * (low + high);
    (shoot(q, length_m, mid, false).end_curvature < 0.0 ? low : high) = mid;
  }
  return shoot(q, length_m, 0.5 * (low + high), true).solution;
}

double overhangForChordAngle(double rigidity_N_m, double weight_N_per_m2, double angle_rad) {
  // The chord steepens monotonically with the overhang; the bending length c = (B / w)^(1/3) sets the
  // scale, and the standard's answer is near 2c.
  const double c = std::cbrt(rigidity_N_m / weight_N_per_m2);
  const auto chord_angle = [&](double overhang_m) {
    const ElasticaSolution tip = solveHeavyCantilever(rigidity_N_m, weight_N_per_m2, overhang_m);
    return std::atan2(tip.tip_drop_m, tip.tip_reach_m);
  };
  // Bracketed from below: far past the answer the shooting could meet strips curled beyond vertical.
  double low = 0.5 * c;
  double high = c;
  while (chord_angle(high) < angle_rad && high < kLongestOverhangInBendingLengths * c) {
    low = high;
    high *= 2.0;
  }
  for (int i = 0; i < kBisections; ++i) {
    const double mid = 0.5 * (low + high);
    (chord_angle(mid) < angle_rad ? low : high) = mid;
  }
  return 0.5 * (low + high);
}

SceneOptions cantileverScene(const MaterialOptions& material, BendModel bend_model, double overhang_m, int cols) {
  SceneOptions scene;
  // A textile test measures where the physics comes to rest, not where the cloth stopped being computed.
  scene.sleep_speed_m_per_s = 0.0;
  scene.name = "cantilever";
  // Columns 0 and 1 are pinned: their slope is the clamp's, at the midpoint between them. The clamp
  // line is there (x = 0), so the free length runs from there to the last of the cols + 1 columns; put
  // at column 1 instead, the strip would be half a cell longer than it is said to be, an error of
  // 2 h / l in the drop.
  const double spacing_m = overhang_m / (cols - 0.5);
  scene.cols = cols + 1;
  scene.rows = std::max(kMinStripRows, static_cast<int>(std::lround(kCantileverStripWidth_m / spacing_m)) + 1);
  scene.width_m = cols * spacing_m;
  scene.height_m = kCantileverStripWidth_m;
  scene.origin_m = Eigen::Vector3d(-0.5 * spacing_m, -0.5 * kCantileverStripWidth_m, 0.0);
  scene.u_axis = Eigen::Vector3d::UnitX();
  scene.v_axis = Eigen::Vector3d::UnitY();
  scene.has_material = true;
  scene.material = material;
  scene.bend_model = bend_model;
  scene.pins.clear();
  for (int r = 0; r < scene.rows; ++r) {
    for (int c = 0; c < 2; ++c) scene.pins.push_back(std::to_string(r * scene.cols + c));
  }
  if (bend_model == BendModel::kSprings) {
    scene.frame_rate_hz = kSpringCantileverFrameRate_hz;
    scene.air_damping_N_s_per_m = kSpringCantileverAirDamping_N_s_per_m;
  } else {
    scene.frame_rate_hz = kCantileverFrameRate_hz;
  }
  scene.integrator = IntegratorKind::kImplicitEuler;
  scene.substeps = SceneOptions::kAutoSubsteps;
  return scene;
}

CantileverMeasurement runCantilever(const SceneOptions& scene, int max_frames) {
  Simulation simulation(scene);
  const int cols = simulation.grid().cols;
  const int rows = simulation.grid().rows;
  const auto tip = [&] {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int r = 0; r < rows; ++r) sum += simulation.state().positions_m.col(r * cols + cols - 1);
    return Eigen::Vector3d(sum / rows);
  };
  CantileverMeasurement measurement;
  Eigen::Vector3d previous = tip();
  for (int frame = 0; frame < max_frames; ++frame) {
    const FrameReport report = simulation.advanceFrame();
    const Eigen::Vector3d now = tip();
    measurement.frames = frame + 1;
    // A frame the guard rolled back moved nothing, and proves nothing.
    const bool settled = report.stable && (now - previous).norm() < kSettledTipMotion_m;
    previous = now;
    if (settled) {
      measurement.settled = true;
      break;
    }
  }
  measurement.tip_drop_m = -previous.z();
  measurement.tip_reach_m = previous.x();
  for (int c = 0; c < cols; ++c) {
    const Eigen::Vector3d p = simulation.state().positions_m.col((rows / 2) * cols + c);
    measurement.profile_m.emplace_back(p.x(), -p.z());
  }
  return measurement;
}

SceneOptions cusickScene(const MaterialOptions& material, BendModel bend_model, int side) {
  SceneOptions scene;
  // A textile test measures where the physics comes to rest, not where the cloth stopped being computed.
  scene.sleep_speed_m_per_s = 0.0;
  scene.name = "cusick";
  scene.rows = side;
  scene.cols = side;
  scene.width_m = kCusickSpecimenDiameter_m;
  scene.height_m = kCusickSpecimenDiameter_m;
  const double radius_m = 0.5 * kCusickSpecimenDiameter_m;
  scene.origin_m = Eigen::Vector3d(-radius_m, -radius_m, kCusickHeight_m);
  scene.u_axis = Eigen::Vector3d::UnitX();
  scene.v_axis = Eigen::Vector3d::UnitY();
  scene.has_material = true;
  scene.material = material;
  scene.bend_model = bend_model;
  scene.outline.shape = OutlineOptions::Shape::kCircle;
  scene.outline.center_m = Eigen::Vector2d(radius_m, radius_m);
  scene.outline.radius_m = radius_m;
  scene.pins.clear();
  const double spacing_m = kCusickSpecimenDiameter_m / (side - 1);
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const Eigen::Vector2d uv(c * spacing_m, r * spacing_m);
      if ((uv - scene.outline.center_m).norm() <= 0.5 * kCusickSupportDiameter_m) {
        scene.pins.push_back(std::to_string(r * side + c));
      }
    }
  }
  scene.integrator = IntegratorKind::kImplicitEuler;
  scene.substeps = SceneOptions::kAutoSubsteps;
  return scene;
}

double projectedArea_m2(const std::vector<int>& triangles, const Eigen::Matrix3Xd& positions_m, double pixel_m) {
  if (triangles.empty()) return 0.0;
  Eigen::Vector2d low(positions_m.row(0).minCoeff(), positions_m.row(1).minCoeff());
  Eigen::Vector2d high(positions_m.row(0).maxCoeff(), positions_m.row(1).maxCoeff());
  const int nx = static_cast<int>(std::ceil((high.x() - low.x()) / pixel_m)) + 1;
  const int ny = static_cast<int>(std::ceil((high.y() - low.y()) / pixel_m)) + 1;
  std::vector<char> covered(static_cast<std::size_t>(nx) * ny, 0);
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const Eigen::Vector2d a = positions_m.col(triangles[t]).head<2>();
    const Eigen::Vector2d b = positions_m.col(triangles[t + 1]).head<2>();
    const Eigen::Vector2d c = positions_m.col(triangles[t + 2]).head<2>();
    const double area2 = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    if (area2 == 0.0) continue;  // seen edge-on from above: no shadow
    const int x0 = std::max(0, static_cast<int>(std::floor((std::min({a.x(), b.x(), c.x()}) - low.x()) / pixel_m)));
    const int x1 = std::min(nx - 1, static_cast<int>(std::ceil((std::max({a.x(), b.x(), c.x()}) - low.x()) / pixel_m)));
    const int y0 = std::max(0, static_cast<int>(std::floor((std::min({a.y(), b.y(), c.y()}) - low.y()) / pixel_m)));
    const int y1 = std::min(ny - 1, static_cast<int>(std::ceil((std::max({a.y(), b.y(), c.y()}) - low.y()) / pixel_m)));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d p = low + pixel_m * Eigen::Vector2d(x + 0.5, y + 0.5);
        // Barycentric signs, either winding.
        const double w0 = ((b - p).x() * (c - p).y() - (b - p).y() * (c - p).x()) / area2;
        const double w1 = ((c - p).x() * (a - p).y() - (c - p).y() * (a - p).x()) / area2;
        const double w2 = 1.0 - w0 - w1;
        if (w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0) covered[static_cast<std::size_t>(y) * nx + x] = 1;
      }
    }
  }
  return static_cast<double>(std::count(covered.begin(), covered.end(), 1)) * pixel_m * pixel_m;
}

namespace {

/// The hem's distance from centre_m (xy plane) in kFoldBins angular bins: the farthest hem particle in
/// each, empty bins filled from their neighbours.
std::vector<double> hemProfile(const ClothGrid& grid, const Eigen::Matrix3Xd& positions_m, const Eigen::Vector2d& centre_m) {
  std::vector<double> reach(kFoldBins, -1.0);
  for (int r = 0; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const int p = grid.index(r, c);
      if (!grid.isActive(p)) continue;
      const bool hem = r == 0 || c == 0 || r == grid.rows - 1 || c == grid.cols - 1 || !grid.isActive(p - 1) ||
                       !grid.isActive(p + 1) || !grid.isActive(p - grid.cols) || !grid.isActive(p + grid.cols);
      if (!hem) continue;
      const Eigen::Vector2d d = positions_m.col(p).head<2>() - centre_m;
      const double angle = std::atan2(d.y(), d.x()) + kTwoPi / 2.0;
      const int bin = std::min(kFoldBins - 1, static_cast<int>(angle / kTwoPi * kFoldBins));
      reach[bin] = std::max(reach[bin], d.norm());
    }
  }
  for (int pass = 0; pass < kFoldBins; ++pass) {
    bool filled = true;
    for (int i = 0; i < kFoldBins; ++i) {
      if (reach[i] >= 0.0) continue;
      filled = false;
      const double left = reach[(i + kFoldBins - 1) % kFoldBins];
      const double right = reach[(i + 1) % kFoldBins];
      if (left >= 0.0 || right >= 0.0) reach[i] = std::max(left, right);
    }
    if (filled) break;
  }
  return reach;
}

/// Amplitude of wave number n in a profile, m.
double harmonicAmplitude(const std::vector<double>& profile, int n) {
  double re = 0.0;
  double im = 0.0;
  for (int i = 0; i < kFoldBins; ++i) {
    const double angle = 2.0 * kPi * n * (i + 0.5) / kFoldBins;
    re += profile[i] * std::cos(angle);
    im += profile[i] * std::sin(angle);
  }
  return 2.0 * std::hypot(re, im) / kFoldBins;
}

}  // namespace

int countFolds(const ClothGrid& grid, const Eigen::Matrix3Xd& positions_m, const Eigen::Vector2d& centre_m) {
  // The number of folds is the wave number whose amplitude in the hem's r(theta) grew most over the flat
  // specimen's (whose staircase hem on the square grid has waves of its own, of a fraction of a spacing),
  // between kFewestFolds and kMostFolds; none when no wave grew by kFoldGrowthSpacings spacings.
  const std::vector<double> draped = hemProfile(grid, positions_m, centre_m);
  const std::vector<double> flat = hemProfile(grid, grid.rest_positions_m, centre_m);
  int best = 0;
  double best_growth_m = 0.0;
  for (int n = kFewestFolds; n <= kMostFolds; ++n) {
    const double growth_m = harmonicAmplitude(draped, n) - harmonicAmplitude(flat, n);
    if (growth_m > best_growth_m) {
      best_growth_m = growth_m;
      best = n;
    }
  }
  const double spacing_m = (grid.rest_positions_m.col(1) - grid.rest_positions_m.col(0)).norm();
  return best_growth_m >= kFoldGrowthSpacings * spacing_m ? best : 0;
}

CusickMeasurement runCusick(const SceneOptions& scene, double seconds) {
  Simulation simulation(scene);
  const int frames = static_cast<int>(std::lround(seconds * scene.frame_rate_hz));
  const int last_second = frames - static_cast<int>(std::lround(scene.frame_rate_hz));
  CusickMeasurement measurement;
  Eigen::Matrix3Xd second_before = simulation.state().positions_m;
  for (int frame = 0; frame < frames; ++frame) {
    if (frame == last_second) second_before = simulation.state().positions_m;
    simulation.advanceFrame();
  }
  measurement.frames = frames;
  measurement.positions_m = simulation.state().positions_m;
  const ClothGrid& grid = simulation.grid();
  measurement.triangles = grid.triangles;
  double motion_m = 0.0;
  for (int p = 0; p < grid.particleCount(); ++p) {
    if (grid.isActive(p)) motion_m = std::max(motion_m, (measurement.positions_m.col(p) - second_before.col(p)).norm());
  }
  measurement.last_second_motion_m = motion_m;
  const double support_m2 = kPi * 0.25 * kCusickSupportDiameter_m * kCusickSupportDiameter_m;
  const double specimen_m2 = kPi * 0.25 * kCusickSpecimenDiameter_m * kCusickSpecimenDiameter_m;
  measurement.projected_area_m2 = projectedArea_m2(grid.triangles, measurement.positions_m, kCusickPixel_m);
  measurement.drape_coefficient = (measurement.projected_area_m2 - support_m2) / (specimen_m2 - support_m2);
  measurement.folds = countFolds(grid, measurement.positions_m, Eigen::Vector2d(0.0, 0.0));
  return measurement;
}

}  // namespace cloth_sim::core
