#include "cloth_sim/core/textile_tests.h"

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

}  // namespace cloth_sim::core
