#include "cloth_sim/core/scripted_fold.h"

#include "cloth_sim/core/constants.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace cloth_sim::core {

namespace {

double smoothstep(double u) {
  const double c = std::clamp(u, 0.0, 1.0);
  return c * c * (3.0 - 2.0 * c);
}

}  // namespace

std::vector<int> ScriptedFold::heldParticles(const ClothGrid& grid) const {
  return {grid.index(grid.rows - 1, 0), grid.index(grid.rows - 1, grid.cols - 1)};
}

std::string ScriptedFold::holdProblem(const ClothGrid& grid) const {
  for (const int particle : heldParticles(grid)) {
    if (!grid.isActive(particle)) return "particle " + std::to_string(particle) + " is outside the cloth's outline";
  }
  return "";
}

std::vector<Eigen::Vector3d> ScriptedFold::handPositions_m(const ClothGrid& grid, double thickness_m, double time_s,
                                                           const Eigen::Matrix3Xd& positions_m) const {
  const Eigen::Matrix3Xd& rest = grid.rest_positions_m;
  // The cloth's normal, away from what it lies on: u x v (the first particles of a row and a column).
  const Eigen::Vector3d along_row = rest.col(grid.index(0, grid.cols - 1)) - rest.col(0);
  const Eigen::Vector3d along_column = rest.col(grid.index(grid.rows - 1, 0)) - rest.col(0);
  const Eigen::Vector3d normal = along_row.cross(along_column).normalized();
  const double angle_rad = kPi * smoothstep((time_s - start_s) / carry_s);
  const double set_down_m = kSetDownThicknesses * thickness_m * angle_rad / kPi;
  const double allowance_m = kLoopThicknesses * thickness_m;
  std::vector<Eigen::Vector3d> hands;
  const std::vector<int> held = heldParticles(grid);
  const int targets[] = {grid.index(0, 0), grid.index(0, grid.cols - 1)};
  for (std::size_t h = 0; h < held.size(); ++h) {
    const Eigen::Vector3d from = rest.col(held[h]);
    const Eigen::Vector3d to = rest.col(targets[h]);
    const Eigen::Vector3d center = 0.5 * (from + to);
    const Eigen::Vector3d radius = from - center;
    // How far the fold has dragged the corner in (along the radius, towards the fold line).
    const double dragged_m = (positions_m.col(targets[h]) - to).dot(radius.normalized());
    const double short_m = std::max(allowance_m, dragged_m) * angle_rad / kPi;
    hands.push_back(center + std::cos(angle_rad) * radius + short_m * radius.normalized() +
                    (std::sin(angle_rad) * radius.norm() + set_down_m) * normal);
  }
  return hands;
}

bool ScriptedFold::drive(Simulation& simulation, std::string* error) const {
  const double end_s = simulation.state().time_s + simulation.options().frameDuration_s();
  const std::vector<int> held = heldParticles(simulation.grid());
  if (end_s <= start_s) return true;
  if (end_s > releaseTime_s()) {
    // A hand already let go (or never held) has nothing to release: not an error.
    for (std::size_t h = 0; h < held.size(); ++h) simulation.release(kFirstGraspId + static_cast<std::uint32_t>(h));
    return true;
  }
  const double thickness_m = selfCollisionThickness_m(simulation.options().self_collision, simulation.grid());
  const std::vector<Eigen::Vector3d> hands =
      handPositions_m(simulation.grid(), thickness_m, end_s, simulation.state().positions_m);
  bool every_hand_holds = true;
  for (std::size_t h = 0; h < held.size(); ++h) {
    GraspRequest request;
    request.id = kFirstGraspId + static_cast<std::uint32_t>(h);
    request.particle = held[h];
    request.target_m = hands[h];
    request.stiffness_N_per_m = grasp_stiffness_N_per_m;
    std::string grab_error;
    if (!simulation.grab(request, &grab_error) && every_hand_holds) {
      *error = grab_error;
      every_hand_holds = false;
    }
  }
  return every_hand_holds;
}

}  // namespace cloth_sim::core
