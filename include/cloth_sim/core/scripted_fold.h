// A two-handed fold, scripted (issue 15's `fold` scene): what a person folding a towel in half does, as
// grasp requests over time. The same script drives the tests, `cloth_bench --fold` and, through the
// ~grasp topic, scripts/fold_demo_driver.py.
//
// The hands take the two corners of the cloth's last row and carry them over the middle on a half circle
// (in the plane of the rows' direction and the cloth's normal u x v) over the first row's corners, ending
// kSetDownThicknesses thicknesses above them and kLoopThicknesses thicknesses short of where they lay at
// rest (towards the fold), or over where they are now if the fold has dragged them in further than that;
// they hold there a moment (following the corners, should the fold drag them further), then let go.
#pragma once

#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/simulation.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim::core {

struct ScriptedFold {
  double start_s = 0.2;   ///< the hands close on the corners
  double carry_s = 1.6;   ///< and carry them over in this long (smoothstep along the half circle)
  double hold_s = 0.4;    ///< then hold before letting go
  double grasp_stiffness_N_per_m = 0.0;  ///< 0: the scene's grasp_stiffness
  /// Where the hands set the corners down: this many thicknesses above the first row.
  static constexpr double kSetDownThicknesses = 1.5;
  /// How far short of the first row's rest corners the hands stop at least, in thicknesses: the fold's
  /// loop, a half circle of diameter h, takes pi h / 2 of the cloth's length. Set down exactly over the
  /// first row, the moved half had no length left for the loop, and the fold line's springs were held at
  /// 60 % strain. Where the fold has dragged the corners in further, the hands stop over them.
  static constexpr double kLoopThicknesses = kPi / 2.0;
  /// Grasp ids the script uses (first hand, second hand).
  static constexpr std::uint32_t kFirstGraspId = 7001;

  double releaseTime_s() const { return start_s + carry_s + hold_s; }
  /// The particles the hands hold: the last row's corners.
  std::vector<int> heldParticles(const ClothGrid& grid) const;
  /// Where the hands are at time_s, world frame (one per held particle), for a cloth that lay flat on its
  /// rest grid, self-collision `thickness_m`, and particles now at positions_m. The fold drags the lower
  /// half towards the fold line (2.4-4.2 cm on the `fold` scene's towel, at every size measured), and the
  /// hands stop over where its corners are now if that is further in than the loop's allowance: aimed at
  /// the rest grid alone, they set the upper edge down past the lower one wherever the allowance (which
  /// shrinks with the thickness) is the smaller, and at 96 x 96 and 128 x 128 it hung off the lower
  /// layer's edge onto the floor, stretched 30 % over that step and held there by friction.
  std::vector<Eigen::Vector3d> handPositions_m(const ClothGrid& grid, double thickness_m, double time_s,
                                               const Eigen::Matrix3Xd& positions_m) const;
  /// Why the hands cannot fold this cloth ("particle 90 is outside the cloth's outline": a corner they
  /// take that the outline removes, which Simulation::grab refuses), or empty. Ask before driving: without
  /// its hands the fold folds nothing.
  std::string holdProblem(const ClothGrid& grid) const;
  /// Grabs, moves or releases the hands for the frame that starts at simulation.state().time_s (call
  /// before advanceFrame): the targets are where the hands are at the frame's end. False with *error
  /// (Simulation::grab's refusal) if a hand could not take or move its corner; the other hand is driven
  /// all the same.
  [[nodiscard]] bool drive(Simulation& simulation, std::string* error) const;
};

}  // namespace cloth_sim::core
