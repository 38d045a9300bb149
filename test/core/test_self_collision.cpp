// Self-collision (issue 15): the cloth never passes through itself. Every scenario is checked frame by
// frame with the independent mesh checker (mesh_check.h: triangle pairs that share no particle and where
// an edge of one passes through the other), itself tested on hand-made sheets in test_mesh_check.cpp.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/mesh_check.h"
#include "cloth_sim/core/scripted_fold.h"
#include "cloth_sim/core/self_collision.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/core/spatial_hash.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <iterator>
#include <limits>
#include <random>
#include <set>

namespace cloth_sim::core {
namespace {

using test::loadBuiltinScene;

int crossings(const Simulation& simulation) {
  return static_cast<int>(crossingTrianglePairs(simulation.grid().triangles, simulation.state().positions_m).size());
}

/// The closest two particles that are not exempt (further than the thickness apart on the rest grid), m.
double closestLayers_m(const Simulation& simulation) {
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  const Eigen::Matrix3Xd& rest = simulation.grid().rest_positions_m;
  const double h = selfCollisionThickness_m(simulation.options().self_collision, simulation.grid());
  double closest = std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    for (Eigen::Index j = i + 1; j < x.cols(); ++j) {
      if ((rest.col(i) - rest.col(j)).norm() <= SelfCollision::kExemptRestThicknesses * h) continue;
      closest = std::min(closest, (x.col(i) - x.col(j)).norm());
    }
  }
  return closest;
}

TEST(SelfCollisionKernels, ClosestApproachOfTwoStraightPaths) {
  // Head on through each other: they meet.
  EXPECT_NEAR(closestApproach_m({0, 0, 0}, {0, 0, 1}, {0, 0, 1}, {0, 0, 0}), 0.0, 1e-15);
  // Passing side by side 0.3 apart.
  EXPECT_NEAR(closestApproach_m({0, 0, 0}, {0, 0, 0}, {0.3, 0, -1}, {0.3, 0, 1}), 0.3, 1e-15);
  // Closest at the end of the path.
  EXPECT_NEAR(closestApproach_m({0, 0, 0}, {0, 0, 0}, {0, 0, 2}, {0, 0, 1}), 1.0, 1e-15);
  // Moving together: the distance never changes.
  EXPECT_NEAR(closestApproach_m({0, 0, 0}, {5, 5, 5}, {1, 0, 0}, {6, 5, 5}), 1.0, 1e-15);
}

/// Every pair (i < j) whose boxes overlap and that keep accepts, by testing all of them.
template <typename Keep>
std::vector<std::pair<int, int>> overlappingPairs(const Eigen::Matrix3Xd& start, const Eigen::Matrix3Xd& end,
                                                  double reach, const Keep& keep) {
  const Eigen::Matrix3Xd lo = start.cwiseMin(end).array() - 0.5 * reach;
  const Eigen::Matrix3Xd hi = start.cwiseMax(end).array() + 0.5 * reach;
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < start.cols(); ++i) {
    for (int j = i + 1; j < start.cols(); ++j) {
      const bool overlap = (lo.col(i).array() <= hi.col(j).array()).all() && (lo.col(j).array() <= hi.col(i).array()).all();
      if (overlap && keep(i, j)) pairs.emplace_back(i, j);
    }
  }
  return pairs;
}

TEST(SweptPairFinder, FindsExactlyThePairsWhoseGrownSweptBoxesOverlap) {
  std::mt19937 random(15);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int count = 400;
  Eigen::Matrix3Xd start(3, count);
  Eigen::Matrix3Xd end(3, count);
  for (int i = 0; i < count; ++i) {
    start.col(i) << unit(random), unit(random), unit(random);
    // Most barely move, a few move far (they make the cells larger).
    const double travel = i % 50 == 0 ? 0.5 : 0.02;
    end.col(i) = start.col(i) + travel * Eigen::Vector3d(unit(random) - 0.5, unit(random) - 0.5, unit(random) - 0.5);
  }
  const double reach = 0.05;
  const auto keep = [](int i, int j) { return (i + j) % 7 != 0; };
  SweptPairFinder finder;
  std::vector<std::pair<int, int>> found;
  finder.find(start, end, reach, keep, &found);
  const std::vector<std::pair<int, int>> expected = overlappingPairs(start, end, reach, keep);
  EXPECT_GT(expected.size(), 100u);
  EXPECT_EQ(found, expected);  // the same pairs, in increasing order
}

TEST(SweptPairFinder, FindsTheSamePairsOnAFoldedSheetAtRestAndWhileOneHalfIsThrown) {
  // A 30 x 30 sheet, 1 cm apart, folded over itself 1.5 cm above its lower half, about a corner at
  // negative coordinates (cells on both sides of zero), and the grid's neighbours turned away as
  // self-collision does. At rest (start = end: the list self-collision keeps) every box spans the same
  // cells; then the upper half is thrown down and sideways, so its boxes are several cells wide and the
  // lower half's one.
  const int side = 30;
  const double spacing = 0.01;
  Eigen::Matrix3Xd rest(3, side * side);
  for (int r = 0; r < side; ++r) {
    for (int c = 0; c < side; ++c) {
      const bool upper = r >= side / 2;
      const double v = upper ? (side - 1 - r) * spacing : r * spacing;
      rest.col(r * side + c) << -0.2 + c * spacing, -0.1 + v, upper ? 0.015 : 0.0;
    }
  }
  const auto apart = [side](int i, int j) {
    const int dr = j / side - i / side;
    const int dc = j % side - i % side;
    return dr * dr + dc * dc > 9;
  };
  SweptPairFinder finder;
  std::vector<std::pair<int, int>> found;
  const double reach = 0.035;
  finder.find(rest, rest, reach, apart, &found);
  const std::vector<std::pair<int, int>> at_rest = overlappingPairs(rest, rest, reach, apart);
  EXPECT_GT(at_rest.size(), 10000u);
  EXPECT_EQ(found, at_rest);

  Eigen::Matrix3Xd thrown = rest;
  for (int i = side * side / 2; i < side * side; ++i) thrown.col(i) += Eigen::Vector3d(0.03, -0.05, -0.1);
  finder.find(rest, thrown, reach, apart, &found);
  const std::vector<std::pair<int, int>> while_thrown = overlappingPairs(rest, thrown, reach, apart);
  EXPECT_GT(while_thrown.size(), at_rest.size());
  EXPECT_EQ(found, while_thrown);
}

TEST(SelfCollisionOptions, TheDefaultThicknessIsOneAndAHalfCellDiagonals) {
  SceneOptions options = loadBuiltinScene("fold");
  Simulation simulation(options);
  const double spacing = 0.5 / 23.0;
  EXPECT_NEAR(selfCollisionThickness_m(options.self_collision, simulation.grid()), 1.5 * std::sqrt(2.0) * spacing, 1e-12);
  options.self_collision.thickness_m = 0.01;
  EXPECT_EQ(selfCollisionThickness_m(options.self_collision, simulation.grid()), 0.01);
}

/// A fold run to its end: the frames' crossings and what the folded towel looks like.
struct FoldOutcome {
  int worst_crossings = 0;
  int forced = 0;
  double mean_mirror_gap_m = 0.0;   ///< mean distance of each moved particle from its mirror particle
  double moved_half_above = 0.0;    ///< share of moved-half particles above their mirror particle
  double rest_creep_m_per_s = 0.0;  ///< fastest particle over the last second, by displacement
  double closest_layers_m = 0.0;    ///< closest exempt-free particle pair at the end
  double thickness_m = 0.0;
  /// Self-collision's stretch ratio, the largest a frame ended with once the hands are past the top of
  /// their arc (laying the upper half down, holding, letting go, at rest).
  double worst_stretch_ratio = 0.0;
};

FoldOutcome runFold(int side, IntegratorKind integrator = IntegratorKind::kImplicitEuler) {
  SceneOptions options = loadBuiltinScene("fold");
  options.rows = options.cols = side;
  options.integrator = integrator;
  options.substeps = SceneOptions::kAutoSubsteps;
  options.sleep_speed_m_per_s = 0.0;  // the creep measured is the physics': a sleeping towel does not move
  Simulation simulation(options);
  const ScriptedFold fold;
  FoldOutcome outcome;
  outcome.thickness_m = selfCollisionThickness_m(options.self_collision, simulation.grid());
  const double settle_s = 4.0;
  const double creep_window_s = 1.0;
  Eigen::Matrix3Xd window_start;
  std::string error;
  while (simulation.state().time_s < fold.releaseTime_s() + settle_s + creep_window_s - 1e-9) {
    EXPECT_TRUE(fold.drive(simulation, &error)) << error;
    const FrameReport report = simulation.advanceFrame();
    EXPECT_TRUE(report.stable) << report.reason;
    outcome.forced += report.self_collision.forced;
    if (simulation.state().time_s > fold.start_s + fold.carry_s / 2.0) {
      outcome.worst_stretch_ratio = std::max(outcome.worst_stretch_ratio, report.self_collision.stretch_ratio);
    }
    outcome.worst_crossings = std::max(outcome.worst_crossings, crossings(simulation));
    if (window_start.size() == 0 && simulation.state().time_s >= fold.releaseTime_s() + settle_s - 1e-9) {
      window_start = simulation.state().positions_m;
    }
  }
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  outcome.rest_creep_m_per_s = (x - window_start).colwise().norm().maxCoeff() / creep_window_s;
  const ClothGrid& grid = simulation.grid();
  int moved = 0;
  int above = 0;
  for (int r = grid.rows - grid.rows / 2; r < grid.rows; ++r) {
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector3d mine = x.col(grid.index(r, c));
      const Eigen::Vector3d mirror = x.col(grid.index(grid.rows - 1 - r, c));
      outcome.mean_mirror_gap_m += (mine - mirror).norm();
      above += mine.z() > mirror.z() ? 1 : 0;
      ++moved;
    }
  }
  outcome.mean_mirror_gap_m /= moved;
  outcome.moved_half_above = static_cast<double>(above) / moved;
  outcome.closest_layers_m = closestLayers_m(simulation);
  std::cout << "fold " << side << "x" << side << ": crossings " << outcome.worst_crossings << ", forced " << outcome.forced
            << ", mirror gap " << outcome.mean_mirror_gap_m << " m (h " << outcome.thickness_m << "), above "
            << outcome.moved_half_above << ", creep " << outcome.rest_creep_m_per_s << " m/s, closest "
            << outcome.closest_layers_m << " m, stretch ratio at worst " << outcome.worst_stretch_ratio << "\n";
  return outcome;
}

void expectAFold(const FoldOutcome& outcome, double creep_bound_m_per_s) {
  EXPECT_EQ(outcome.worst_crossings, 0);
  EXPECT_EQ(outcome.forced, 0);
  // The guarantee in force in every frame from where the upper half comes down: laying it down, the
  // fold line's springs took it out of force at one implicit step (stretch ratio 1.13 at 24 x 24,
  // measured), and `auto` refines such a frame (Simulation::computeFrame). Not before: lifting the
  // corners, the hands themselves stretch the cloth beside them (1.002 at 48 x 48, with two substeps too).
  EXPECT_LE(outcome.worst_stretch_ratio, SelfCollision::kGuaranteedStretchRatio);
  // The moved half lies on the other: on top, within a few thicknesses of its mirror image.
  EXPECT_GE(outcome.moved_half_above, 0.95);
  EXPECT_LT(outcome.mean_mirror_gap_m, 3.0 * outcome.thickness_m);
  // At rest: no jitter or creep, the layers a thickness apart.
  EXPECT_LT(outcome.rest_creep_m_per_s, creep_bound_m_per_s);
  EXPECT_GE(outcome.closest_layers_m, 0.9 * outcome.thickness_m);
}

/// The bound: each particle of a folded towel at rest moves less than 1 mm per second. Measured:
/// 7e-5 m/s at 24 x 24, 2e-6 m/s at 48 x 48, since static friction puts back what the floor holds
/// (contact.cpp, respondAndTestStick); before, the whole towel drifted at 0.5-1.3 mm/s.
constexpr double kRestCreep_m_per_s = 1e-3;

/// Stiller than the issue asks: static friction reads the cloth's forces on the floor, not the step's
/// numerics (Integrator::subtractSolveShortfall, forces read on the surface), and holds the towel to
/// rounding (5e-17 m/s, measured); reading them as the step left them, it crept 3.5e-5 to 7e-5 m/s.
constexpr double kStillTowel_m_per_s = 1e-9;

TEST(SelfCollisionFold, A24x24TowelFoldedInHalfNeverCrossesItselfAndLiesFolded) {
  const FoldOutcome outcome = runFold(24);
  expectAFold(outcome, kRestCreep_m_per_s);
  EXPECT_LT(outcome.rest_creep_m_per_s, kStillTowel_m_per_s);
}

TEST(SelfCollisionFold, A48x48TowelFoldedInHalfNeverCrossesItselfAndLiesFolded) {
  expectAFold(runFold(48), kRestCreep_m_per_s);
}

TEST(ScriptedFoldHands, StopOverTheFirstRowsCornersWhereTheFoldHasDraggedThemInFurtherThanTheAllowance) {
  SceneOptions options = loadBuiltinScene("fold");
  const Simulation simulation(options);
  const ClothGrid& grid = simulation.grid();
  const ScriptedFold fold;
  const double thickness_m = selfCollisionThickness_m(options.self_collision, grid);
  const double allowance_m = ScriptedFold::kLoopThicknesses * thickness_m;
  const double carried_s = fold.start_s + fold.carry_s;  // the half circle done
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();  // the fold scene's u x v
  const Eigen::Matrix3Xd& rest = grid.rest_positions_m;
  const int corners[] = {grid.index(0, 0), grid.index(0, grid.cols - 1)};
  // Towards the fold line: from the first row towards the last.
  const Eigen::Vector3d inwards = (rest.col(grid.index(grid.rows - 1, 0)) - rest.col(0)).normalized();
  const Eigen::Vector3d set_down_m = ScriptedFold::kSetDownThicknesses * thickness_m * up;
  constexpr double kExact_m = 1e-12;

  // Corners where they lay, or dragged in by less than the allowance, or out: the allowance short of them.
  for (const double dragged_m : {0.0, 0.5 * allowance_m, -0.01}) {
    Eigen::Matrix3Xd positions = rest;
    for (const int corner : corners) positions.col(corner) += dragged_m * inwards;
    const std::vector<Eigen::Vector3d> hands = fold.handPositions_m(grid, thickness_m, carried_s, positions);
    ASSERT_EQ(hands.size(), 2u);
    for (int h = 0; h < 2; ++h) {
      const Eigen::Vector3d expected = rest.col(corners[h]) + allowance_m * inwards + set_down_m;
      EXPECT_LT((hands[h] - expected).norm(), kExact_m) << "dragged " << dragged_m << " m, hand " << h;
    }
  }
  // Dragged in by twice the allowance: over where the corners are now.
  Eigen::Matrix3Xd positions = rest;
  for (const int corner : corners) positions.col(corner) += 2.0 * allowance_m * inwards;
  const std::vector<Eigen::Vector3d> hands = fold.handPositions_m(grid, thickness_m, carried_s, positions);
  for (int h = 0; h < 2; ++h) {
    EXPECT_LT((hands[h] - (positions.col(corners[h]) + set_down_m)).norm(), kExact_m) << "hand " << h;
  }
}

/// Drives `fold` on `simulation` up to the first frame whose end is past the hands' closing (each frame
/// before it asks nothing of the hands), then drives that frame: what drive() says of it.
bool driveUntilTheHandsClose(const ScriptedFold& fold, Simulation& simulation, std::string* error) {
  while (simulation.state().time_s + simulation.options().frameDuration_s() <= fold.start_s) {
    if (!fold.drive(simulation, error)) return false;
    simulation.advanceFrame();
  }
  return fold.drive(simulation, error);
}

TEST(ScriptedFoldHands, SayWhyTheyCannotTakeACornerTheOutlineRemovesInsteadOfFoldingNothing) {
  // drive() dropped Simulation::grab's refusals: on a round towel (no corners) `cloth_bench --fold` timed
  // a fold in which no hand ever held the cloth.
  constexpr int kSide = 10;
  SceneOptions options = loadBuiltinScene("fold");
  options.rows = options.cols = kSide;
  const ScriptedFold fold;
  std::string error;
  Simulation whole(options);
  EXPECT_EQ(fold.holdProblem(whole.grid()), "");
  EXPECT_TRUE(driveUntilTheHandsClose(fold, whole, &error)) << error;
  EXPECT_EQ(whole.grasps().size(), 2u) << "the hands hold both corners of the whole towel";

  // The fold scene's towel is 0.5 m square: a circle inscribed in it keeps no corner.
  options.outline.shape = OutlineOptions::Shape::kCircle;
  options.outline.center_m = Eigen::Vector2d(0.25, 0.25);
  options.outline.radius_m = 0.25;
  Simulation round(options);
  const std::string refusal =
      "particle " + std::to_string(fold.heldParticles(round.grid()).front()) + " is outside the cloth's outline";
  EXPECT_EQ(fold.holdProblem(round.grid()), refusal);
  EXPECT_FALSE(driveUntilTheHandsClose(fold, round, &error));
  EXPECT_NE(error.find(refusal), std::string::npos) << error;
  EXPECT_TRUE(round.grasps().empty());
}

TEST(SelfCollisionFold, OnAFineGridTheUpperEdgeLandsOnTheLowerLayerNotPastIt) {
  // The fold drags the lower half about 2.4 cm towards the fold line at every size, and the loop's
  // allowance shrinks with the thickness: aimed at the rest grid, the hands set a 96 x 96 towel's upper
  // edge down 1 cm past the lower one, where it hung onto the floor over the lower layer's edge, 29 %
  // stretched and held by friction, and `auto` stayed at 8 steps a frame (measured before the hands
  // followed the dragged corners; ScriptedFold::handPositions_m).
  constexpr int kSide = 96;
  SceneOptions options = loadBuiltinScene("fold");
  options.rows = options.cols = kSide;
  Simulation simulation(options);
  const ScriptedFold fold;
  const double settle_s = 1.8;
  FrameReport report;
  std::string error;
  while (simulation.state().time_s < fold.releaseTime_s() + settle_s - 1e-9) {
    ASSERT_TRUE(fold.drive(simulation, &error)) << error;
    report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
  }
  const ClothGrid& grid = simulation.grid();
  const double thickness_m = selfCollisionThickness_m(options.self_collision, grid);
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  double lowest_edge_m = std::numeric_limits<double>::infinity();
  for (int c = 0; c < grid.cols; ++c) lowest_edge_m = std::min(lowest_edge_m, x(2, grid.index(grid.rows - 1, c)));
  std::cout << "fold " << kSide << "x" << kSide << " at " << simulation.state().time_s << " s: upper edge's lowest "
            << lowest_edge_m << " m (h " << thickness_m << "), max strain " << report.max_strain << ", substeps "
            << report.substeps_used << ", stretch ratio " << report.self_collision.stretch_ratio << "\n";
  constexpr double kOnTheLowerLayer = 0.9;  // thicknesses above the floor (it rests at 1.0; before, 0.43)
  constexpr double kNoStretchHeld = 0.2;    // strain (it rests at 0.14; before, 0.29)
  EXPECT_GT(lowest_edge_m, kOnTheLowerLayer * thickness_m);  // the whole edge lies on the lower layer
  EXPECT_LT(report.max_strain, kNoStretchHeld);
  EXPECT_LE(report.self_collision.stretch_ratio, SelfCollision::kGuaranteedStretchRatio);
  EXPECT_LE(report.substeps_used, 2);
}

TEST(SelfCollisionFold, WithHandsOneFrameLateNowAndThenTheTowelRestsWithinTheGuarantee) {
  // The demo's hands come through ~grasp from another node (scripts/fold_demo_driver.py): now and then a
  // frame starts before their target for it arrives, and the hands keep the last one. Emulated here: the
  // script skips one frame in ten, drawn from a fixed sequence. At one implicit step a frame such a fold's
  // line jammed as the upper half was laid down and stayed jammed at rest: its springs at 20-25 % strain
  // and a stretch ratio of 0.99-1.02 (fold_demo.test's flakiness). Refined, the fold is round: no spring
  // at rest past kRoundFoldStrain, the stretch ratio 0.92-0.93.
  constexpr int kLateOneIn = 10;
  constexpr double kRoundFoldStrain = 0.1;
  for (unsigned seed = 0; seed < 4; ++seed) {
    SceneOptions options = loadBuiltinScene("fold");
    Simulation simulation(options);
    const ScriptedFold fold;
    std::mt19937 late(seed);
    const double end_s = fold.releaseTime_s() + 2.0;
    FrameReport report;
    std::string error;
    while (simulation.state().time_s < end_s - 1e-9) {
      const bool letting_go = simulation.state().time_s + options.frameDuration_s() > fold.releaseTime_s();
      if (letting_go || late() % kLateOneIn != 0) {
        ASSERT_TRUE(fold.drive(simulation, &error)) << error;
      }
      report = simulation.advanceFrame();
      ASSERT_TRUE(report.stable) << report.reason;
    }
    std::cout << "fold with late hands, sequence " << seed << ": at rest, strain " << report.max_strain
              << ", stretch ratio " << report.self_collision.stretch_ratio << "\n";
    EXPECT_LT(report.max_strain, kRoundFoldStrain) << "sequence " << seed;
    EXPECT_LT(report.self_collision.stretch_ratio, SelfCollision::kGuaranteedStretchRatio) << "sequence " << seed;
  }
}

/// A cloth bent into a U on the floor: its first rows lie flat, a half circle of radius `bend_m` turns
/// it back, and its last rows lie flat 2 bend_m above the first, moving at `upper_velocity`.
struct ULayer {
  SceneOptions options;
  ClothState state;
};

ULayer uShapedCloth(int rows, int cols, double bend_m, const Eigen::Vector3d& upper_velocity_m_per_s,
                    IntegratorKind integrator = IntegratorKind::kImplicitEuler) {
  ULayer u;
  SceneOptions& o = u.options;
  o.name = "u";
  o.rows = rows;
  o.cols = cols;
  o.width_m = 0.4;
  const double spacing = o.width_m / (cols - 1);
  o.height_m = spacing * (rows - 1);
  o.origin_m = {-0.2, 0.0, 0.0};
  o.u_axis = Eigen::Vector3d::UnitX();
  o.v_axis = Eigen::Vector3d::UnitY();
  o.mass_kg = 0.2;
  o.pins.clear();
  o.colliders.planes.push_back(PlaneCollider{});
  o.contact.depth_m = 0.003;
  o.contact.friction = 0.6;
  o.springs[static_cast<int>(SpringKind::kBend)].stiffness_N_per_m = 1.0;
  o.self_collision.enabled = true;
  o.self_collision.friction = 0.5;
  o.integrator = integrator;
  o.substeps = SceneOptions::kAutoSubsteps;
  const double flat_m = 0.5 * (o.height_m - kPi * bend_m);
  u.state.positions_m.resize(3, rows * cols);
  u.state.velocities_m_per_s.setZero(3, rows * cols);
  for (int r = 0; r < rows; ++r) {
    const double s = r * spacing;  // arc length along the cloth
    Eigen::Vector2d yz(s, 0.0);
    bool upper = false;
    if (s > flat_m + kPi * bend_m) {
      yz << flat_m - (s - flat_m - kPi * bend_m), 2.0 * bend_m;
      upper = true;
    } else if (s > flat_m) {
      const double angle = (s - flat_m) / bend_m;
      yz << flat_m + bend_m * std::sin(angle), bend_m * (1.0 - std::cos(angle));
    }
    for (int c = 0; c < cols; ++c) {
      u.state.positions_m.col(r * cols + c) << o.origin_m.x() + c * spacing, yz.x(), yz.y();
      if (upper) u.state.velocities_m_per_s.col(r * cols + c) = upper_velocity_m_per_s;
    }
  }
  return u;
}

/// Runs `frames` frames and returns the most crossing triangle pairs seen in any frame.
int worstCrossings(Simulation& simulation, int frames, int* forced = nullptr) {
  int worst = 0;
  for (int f = 0; f < frames; ++f) {
    const FrameReport report = simulation.advanceFrame();
    EXPECT_TRUE(report.stable) << report.reason;
    if (forced != nullptr) *forced += report.self_collision.forced;
    worst = std::max(worst, crossings(simulation));
  }
  return worst;
}

TEST(SelfCollisionThrown, ALayerThrownAt5MetresASecondOntoARestingLayerNeverPassesThroughIt) {
  ULayer u = uShapedCloth(40, 16, 0.1, {0.0, 0.0, -5.0});
  Simulation simulation(u.options);
  std::string error;
  ASSERT_TRUE(simulation.restoreState(u.state, &error)) << error;
  ASSERT_EQ(crossings(simulation), 0);
  int forced = 0;
  EXPECT_EQ(worstCrossings(simulation, 50, &forced), 0);
  EXPECT_EQ(forced, 0);
  // And it did land on the lower layer: the upper rows lie above the lower ones, about a thickness up.
  const double h = selfCollisionThickness_m(u.options.self_collision, simulation.grid());
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  const Eigen::Index last = x.cols() - 1;
  EXPECT_GT(x(2, last), 0.5 * h);
  EXPECT_LT(x(2, last), 3.0 * h);
}

TEST(SelfCollisionThrown, EveryIntegratorKeepsAFallingLayerOffTheLowerOne) {
  for (const IntegratorKind kind : {IntegratorKind::kForwardEuler, IntegratorKind::kSymplecticEuler, IntegratorKind::kMidpoint,
                                    IntegratorKind::kRK4, IntegratorKind::kImplicitEuler}) {
    ULayer u = uShapedCloth(24, 8, 0.08, {0.0, 0.0, -1.0}, kind);
    u.options.air_damping_N_s_per_m = 0.01;  // forward Euler and midpoint need some damping to be stable
    // rk4 with `auto` diverges on this bent cloth's first frame, with self-collision off too (noticed in
    // issue 15's note, left alone here): the explicit methods get a fixed, small step.
    if (kind != IntegratorKind::kImplicitEuler) u.options.substeps = 200;
    Simulation simulation(u.options);
    std::string error;
    ASSERT_TRUE(simulation.restoreState(u.state, &error)) << error;
    EXPECT_EQ(worstCrossings(simulation, 25), 0) << integratorName(kind);
  }
}

TEST(SelfCollisionPile, AClothDroppedOntoABallCrumplesWithoutPassingThroughItself) {
  const SceneOptions options = loadBuiltinScene("pile");
  ASSERT_TRUE(options.self_collision.enabled);
  Simulation simulation(options);
  int forced = 0;
  EXPECT_EQ(worstCrossings(simulation, 150, &forced), 0);
  EXPECT_EQ(forced, 0);
  // It did pile up: draped over the ball's top (0.24 m), and some of it on the floor.
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  EXPECT_GT(x.row(2).maxCoeff(), 0.23);
  EXPECT_LT(x.row(2).minCoeff(), 0.01);
}

/// Whether every particle of triangle a is further than distance_m from every particle of triangle b on the
/// rest grid (the pairs self-collision's guarantee covers).
bool farApartOnTheRestGrid(const ClothGrid& grid, int a, int b, double distance_m) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const int p = grid.triangles[3 * a + i];
      const int q = grid.triangles[3 * b + j];
      if ((grid.rest_positions_m.col(p) - grid.rest_positions_m.col(q)).norm() <= distance_m) return false;
    }
  }
  return true;
}

/// A strip of `rows` x 16 twisted by two hands turning opposite ways, one turn over 3 s while they come
/// 20 % closer, then held for 1 s: each hand holds the two corners of one end and turns about the strip's
/// long axis (y), so the twisted strip buckles and winds around itself. on_frame(simulation, report,
/// positions before the frame) after every frame.
template <typename OnFrame>
void twistStrip(int rows, const OnFrame& on_frame) {
  SceneOptions o;
  o.name = "twist";
  o.rows = rows;
  o.cols = 16;
  o.width_m = 0.14;
  o.height_m = 0.62;
  o.origin_m = {-0.07, -0.31, 0.5};
  o.u_axis = Eigen::Vector3d::UnitX();
  o.v_axis = Eigen::Vector3d::UnitY();
  o.mass_kg = 0.05;
  o.pins.clear();
  o.gravity_m_per_s2.setZero();
  // The paper's bend springs: the two hands wind the strip into a rope, not crease it.
  o.self_collision.enabled = true;
  o.grasp_stiffness_N_per_m = 500.0;
  Simulation simulation(o);
  const ClothGrid& grid = simulation.grid();
  const int held[4] = {grid.index(0, 0), grid.index(0, o.cols - 1), grid.index(o.rows - 1, 0),
                       grid.index(o.rows - 1, o.cols - 1)};
  const double turns = 1.0;
  const double duration_s = 3.0;
  while (simulation.state().time_s < duration_s + 1.0) {
    const double t = std::min(1.0, (simulation.state().time_s + o.frameDuration_s()) / duration_s);
    for (int k = 0; k < 4; ++k) {
      const bool first_end = k < 2;
      const Eigen::Vector3d rest = grid.rest_positions_m.col(held[k]);
      const double angle = (first_end ? 1.0 : -1.0) * 2.0 * kPi * turns * t;
      const double end_y = rest.y() * (1.0 - 0.2 * t);  // the hands come 20 % closer
      const Eigen::Vector3d axis_point(0.0, end_y, 0.5);
      const Eigen::Vector3d arm(rest.x(), 0.0, 0.0);
      GraspRequest request;
      request.id = static_cast<std::uint32_t>(k + 1);
      request.particle = held[k];
      request.target_m = axis_point + Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()) * arm;
      std::string error;
      ASSERT_TRUE(simulation.grab(request, &error)) << error;
    }
    const Eigen::Matrix3Xd before = simulation.state().positions_m;
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    on_frame(simulation, report, before);
  }
}

TEST(SelfCollisionTwist, AStripTwistedByTwoHandsTurningOppositeWaysNeverPassesItsFarPartsThroughItself) {
  constexpr int kRows = 64;
  int worst_far = 0;
  int worst_all = 0;
  int refined_for_crossings = 0;
  twistStrip(kRows, [&](const Simulation& simulation, const FrameReport& report, const Eigen::Matrix3Xd&) {
    const ClothGrid& grid = simulation.grid();
    const double exempt_m =
        SelfCollision::kExemptRestThicknesses * selfCollisionThickness_m(simulation.options().self_collision, grid);
    int far = 0;
    const auto pairs = crossingTrianglePairs(grid.triangles, simulation.state().positions_m);
    for (const auto& [a, b] : pairs) far += farApartOnTheRestGrid(grid, a, b, exempt_m) ? 1 : 0;
    if (!pairs.empty() && worst_all == 0) {
      const int a = grid.triangles[3 * pairs.front().first];
      const int b = grid.triangles[3 * pairs.front().second];
      std::cout << "twist: first crossing at " << simulation.state().time_s << " s, near particles (" << a / grid.cols
                << ", " << a % grid.cols << ") and (" << b / grid.cols << ", " << b % grid.cols << ")\n";
    }
    worst_far = std::max(worst_far, far);
    worst_all = std::max(worst_all, static_cast<int>(pairs.size()));
    refined_for_crossings += report.rejection.find("passed through each other") != std::string::npos ? 1 : 0;
  });
  // The guarantee: no two triangles further apart on the rest grid than the exempt distance cross. Near
  // ones (a crease within 1.6 thicknesses) are the bend springs' to keep apart, and where the hands
  // stretch the strip past the guarantee's edge length, the guard's: it computes a frame in which any
  // crossed again with more substeps (here frames at 2.88 s and 2.96 s, whose first computations crossed
  // one pair each).
  std::cout << "twist: " << worst_all << " crossing pairs at worst, " << worst_far << " of them far apart on the grid, "
            << refined_for_crossings << " frames refined for crossings\n";
  EXPECT_EQ(worst_far, 0);
  EXPECT_EQ(worst_all, 0);
}

TEST(SelfCollisionTwist, AFrameInWhichTrianglesPassedThroughEachOtherSaysSo) {
  // At 32 rows the twist's crossings outlast the guard's refinements (Simulation::kMostCrossingRefinements):
  // every frame that makes one must count it and warn (and only such a frame).
  constexpr int kRows = 32;
  int made = 0;
  int warned = 0;
  twistStrip(kRows, [&](const Simulation& simulation, const FrameReport& report, const Eigen::Matrix3Xd& before) {
    const ClothGrid& grid = simulation.grid();
    const auto after = crossingTrianglePairs(grid.triangles, simulation.state().positions_m);
    const auto was = crossingTrianglePairs(grid.triangles, before);
    std::vector<std::pair<int, int>> new_pairs;
    std::set_difference(after.begin(), after.end(), was.begin(), was.end(), std::back_inserter(new_pairs));
    EXPECT_EQ(report.self_collision.crossed, static_cast<int>(new_pairs.size()))
        << "at " << simulation.state().time_s << " s";
    const bool says_so = report.reason.find("the cloth passed through itself") != std::string::npos;
    EXPECT_EQ(says_so, !new_pairs.empty()) << "at " << simulation.state().time_s << " s: " << report.reason;
    made += new_pairs.empty() ? 0 : 1;
    warned += says_so ? 1 : 0;
  });
  std::cout << "twist at " << kRows << " rows: " << made << " frames made a crossing, " << warned << " said so\n";
  EXPECT_GT(made, 0) << "nothing crossed: this test needs a strip that does";
}

TEST(SelfCollisionSnapshot, AFoldRestoredMidwayContinuesBitForBit) {
  SceneOptions options = loadBuiltinScene("fold");
  Simulation first(options);
  const ScriptedFold fold;
  std::string error;
  for (int f = 0; f < 70; ++f) {  // the hands are carrying the half over
    ASSERT_TRUE(fold.drive(first, &error)) << error;
    first.advanceFrame();
  }
  const SimulationSnapshot snapshot = first.snapshot();
  Simulation second(options);
  ASSERT_TRUE(second.restore(snapshot, &error)) << error;
  for (int f = 0; f < 40; ++f) {
    ASSERT_TRUE(fold.drive(first, &error)) << error;
    ASSERT_TRUE(fold.drive(second, &error)) << error;
    const FrameReport a = first.advanceFrame();
    const FrameReport b = second.advanceFrame();
    EXPECT_EQ(a.self_collision.contacts, b.self_collision.contacts);
  }
  EXPECT_TRUE((first.state().positions_m.array() == second.state().positions_m.array()).all());
  EXPECT_TRUE((first.state().velocities_m_per_s.array() == second.state().velocities_m_per_s.array()).all());
}

TEST(SelfCollisionOff, ASceneWithoutItComputesTheSameBitsAsBefore) {
  // Off costs nothing and changes nothing: the fold scene with self-collision off gives the bits of a
  // run whose options never had the keys (the defaults).
  SceneOptions with_keys = loadBuiltinScene("fold");
  with_keys.self_collision.enabled = false;
  with_keys.self_collision.thickness_m = 0.02;
  SceneOptions without = with_keys;
  without.self_collision = SelfCollisionOptions();
  Simulation a(with_keys);
  Simulation b(without);
  for (int f = 0; f < 20; ++f) {
    const FrameReport report = a.advanceFrame();
    b.advanceFrame();
    EXPECT_EQ(report.self_collision.candidate_pairs, 0);
  }
  EXPECT_TRUE((a.state().positions_m.array() == b.state().positions_m.array()).all());
}

TEST(SelfCollisionRefinement, AutoKeepsNoRefinementThatCannotBringTheGuaranteeBack) {
  // The upper layer of a folded cloth rests on the lower one, which lies on the floor; a hand yanks the
  // lower layer's corner 3 cm outwards with a stiff grasp. The edges beside the hand leave the guarantee
  // at one step and at two alike (the hand's stretch, not the step's): the frame is refined once, and the
  // next one starts from one step again instead of paying twice as much from then on.
  constexpr double kPull_m = 0.03;
  constexpr double kStiffGrasp_N_per_m = 2000.0;
  constexpr int kRows = 40;
  constexpr int kCols = 16;
  const double thickness_m = kDefaultThicknessPerDiagonal * std::sqrt(2.0) * 0.4 / (kCols - 1);
  ULayer u = uShapedCloth(kRows, kCols, thickness_m / 2.0, Eigen::Vector3d::Zero());
  Simulation simulation(u.options);
  ASSERT_NEAR(selfCollisionThickness_m(u.options.self_collision, simulation.grid()), thickness_m, 1e-12);
  std::string error;
  ASSERT_TRUE(simulation.restoreState(u.state, &error)) << error;
  GraspRequest yank;
  yank.id = 1;
  yank.particle = simulation.grid().index(0, 0);
  yank.target_m = simulation.state().positions_m.col(yank.particle) + kPull_m * Eigen::Vector3d(-1.0, -1.0, 0.0).normalized();
  yank.stiffness_N_per_m = kStiffGrasp_N_per_m;
  ASSERT_TRUE(simulation.grab(yank, &error)) << error;
  const FrameReport refined = simulation.advanceFrame();
  ASSERT_TRUE(refined.stable) << refined.reason;
  EXPECT_GT(refined.self_collision.contacts, 0);
  EXPECT_TRUE(refined.recomputed);
  EXPECT_NE(refined.reason.find("self-collision stretch ratio"), std::string::npos) << refined.reason;
  EXPECT_EQ(refined.substeps_used, 2);
  EXPECT_GT(refined.self_collision.stretch_ratio, SelfCollision::kGuaranteedStretchRatio);
  const FrameReport next = simulation.advanceFrame();
  EXPECT_EQ(next.substeps_used, 1) << next.reason;
}

TEST(SelfCollisionRefinement, AFoldedTowelAtRestComesBackFromFourStepsAFrameWithinTheGuarantee) {
  // In the node, hands a frame late now and then leave `auto` at 4 steps a frame by the time the towel
  // lies folded (measured: 4 substeps at rest, 66 ms a frame at 64 x 64). At rest it needs fewer, but its
  // lower layer carries the upper one's weight as a velocity into the floor, which the floor takes off
  // every step: by its velocities the towel never looked calm, and no trial at fewer steps came. By how
  // far its particles move in a frame it is calm, and the trials bring the scale down, each frame within
  // self-collision's guarantee.
  constexpr int kScaleLeftByLateHands = 4;
  constexpr int kScaleAtRest = 2;  // from 2 steps to 1 the fold line sags too far (Simulation::kTrialSettle_m)
  constexpr int kTrialPeriods = 4;
  constexpr double kSettle_s = 1.5;
  SceneOptions options = loadBuiltinScene("fold");
  options.sleep_speed_m_per_s = 0.0;  // the stillness below is the physics', not a sleeping towel's
  Simulation simulation(options);
  const ScriptedFold fold;
  std::string error;
  while (simulation.state().time_s < fold.releaseTime_s() + kSettle_s - 1e-9) {
    ASSERT_TRUE(fold.drive(simulation, &error)) << error;
    ASSERT_TRUE(simulation.advanceFrame().stable);
  }
  SimulationSnapshot late = simulation.snapshot();
  ASSERT_LT(late.guard.auto_scale, kScaleLeftByLateHands) << "the scripted fold itself rests at 4 steps";
  late.guard.auto_scale = kScaleLeftByLateHands;
  ASSERT_TRUE(simulation.restore(late, &error)) << error;
  Eigen::Matrix3Xd last_period_start;
  for (std::uint64_t frame = 0; frame < kTrialPeriods * GuardMemory::kScaleTrialFrames; ++frame) {
    if (frame == (kTrialPeriods - 1) * GuardMemory::kScaleTrialFrames) {
      last_period_start = simulation.state().positions_m;
    }
    const FrameReport report = simulation.advanceFrame();
    ASSERT_TRUE(report.stable) << report.reason;
    EXPECT_LE(report.self_collision.stretch_ratio, SelfCollision::kGuaranteedStretchRatio) << "frame " << frame;
    EXPECT_EQ(crossings(simulation), 0) << "frame " << frame;
  }
  EXPECT_EQ(simulation.guardMemory().auto_scale, kScaleAtRest);
  // Settled where the fewer steps put it (about a millimetre, once), then still.
  const double seconds = GuardMemory::kScaleTrialFrames * options.frameDuration_s();
  EXPECT_LT((simulation.state().positions_m - last_period_start).colwise().norm().maxCoeff() / seconds,
            kRestCreep_m_per_s);
}

TEST(SelfCollisionForced, TwoGrippersDraggingTheLayersThroughEachOtherAreReportedNotHidden) {
  // Nothing can stop two particles that grippers hold (no inverse mass), so the simulation cannot keep
  // them apart; it must say so. A gripper lifts a particle of the lower layer straight up through the
  // upper layer's particle above it, which another gripper holds still.
  ULayer u = uShapedCloth(40, 16, 0.1, Eigen::Vector3d::Zero());
  Simulation simulation(u.options);
  std::string error;
  ASSERT_TRUE(simulation.restoreState(u.state, &error)) << error;
  const Eigen::Matrix3Xd& x = simulation.state().positions_m;
  const int lower = simulation.grid().index(4, 8);
  int upper = -1;  // the upper-layer particle nearest above it
  double nearest = std::numeric_limits<double>::infinity();
  for (int p = 0; p < x.cols(); ++p) {
    const double off = (x.col(p).head<2>() - x.col(lower).head<2>()).norm();
    if (x(2, p) > 0.15 && off < nearest) {
      nearest = off;
      upper = p;
    }
  }
  ASSERT_GE(upper, 0);
  std::vector<int> held;
  GripperRequest hold;
  hold.id = 1;
  hold.frame = "still_hand";
  hold.pose.position_m = x.col(upper);
  hold.particles = {upper};
  ASSERT_TRUE(simulation.attachGripper(hold, &held, &error)) << error;
  GripperRequest lift = hold;
  lift.id = 2;
  lift.frame = "lifting_hand";
  lift.pose.position_m = x.col(lower);
  lift.particles = {lower};
  ASSERT_TRUE(simulation.attachGripper(lift, &held, &error)) << error;
  int forced = 0;
  bool reported = false;
  for (int f = 0; f < 10; ++f) {
    Pose pose = lift.pose;
    pose.position_m.head<2>() = hold.pose.position_m.head<2>();  // straight up through the held particle
    pose.position_m.z() += 0.04 * (f + 1);
    ASSERT_TRUE(simulation.moveGripper(2, pose, &error)) << error;
    const FrameReport report = simulation.advanceFrame();
    forced += report.self_collision.forced;
    if (report.reason.find("pulled the cloth through itself") != std::string::npos) reported = true;
  }
  EXPECT_GT(forced, 0);
  EXPECT_TRUE(reported);
}

}  // namespace
}  // namespace cloth_sim::core
