// The cloth's right-hand side as a standalone object: built from the grid, the scene's physics options,
// the masses and the inputs (grasps, pin hooks, wind), it gives the forces and their differential that
// the integrators ask for, and answers for the constraints (pins on hooks) that the implicit solver filters
// by asking its Kinematics (kinematics.h), rebuilt from the options and inputs by refreshConstraints.
// The springs run through the stencil kernels (stencil.h) on structure-of-arrays copies of the fields,
// on options.threads threads from 4096 particles up (src/core/parallel.h); every value is computed by one thread in a fixed
// order, so the results are bit-identical whatever the thread count.
#pragma once

#include "cloth_sim/core/curvature_bending.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/grid_matrix.h"
#include "cloth_sim/core/inputs.h"
#include "cloth_sim/core/integrators.h"
#include "cloth_sim/core/kinematics.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/stencil.h"

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cloth_sim::core {

class ClothForceModel final : public Dynamics {
 public:
  /// Keeps references: grid, options, masses and inputs must outlive the model. Options and inputs may
  /// change between calls (live tuning, grasps); call refreshConstraints after the pins, their hooks, the
  /// grasps or the options (the pins' swing and travel, the spheres) change.
  ClothForceModel(const ClothGrid& grid, const SceneOptions& options, const Eigen::VectorXd& mass_kg,
                  const ClothInputs& inputs);

  /// Rebuilds the bodies from the options and inputs (Kinematics::setScene) and which particles are
  /// constrained: a pin is on its hook unless a grasp holds it, and a gripper holds its particles.
  void refreshConstraints();
  /// False for a grasp of a particle a gripper holds (as of refreshConstraints): the particle moves with
  /// the gripper, so the grasp's spring and force do not act on it, nor enter the gripper's wrench, until
  /// the gripper lets go. The force model's copy of the rule (forces, differentials, energy), cached; the
  /// stability guard asks ClothInputs::gripperHolding, the same rule, for its bounds.
  bool graspActs(const Grasp& grasp) const {
    return gripper_held_.empty() || gripper_held_[static_cast<std::size_t>(grasp.particle)] == 0;
  }
  /// Puts every held particle (hooked pins, gripped particles) where its body holds it at time_s, with the
  /// velocity of that point of the body.
  void enforceConstraints(double time_s, ClothState& state) const { kinematics_.enforce(time_s, state); }
  /// The bodies that move the cloth by prescription (pins' hooks, spheres, grippers, frame colliders), as
  /// of refreshConstraints.
  const Kinematics& kinematics() const { return kinematics_; }

  void forces(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s, double time_s,
              Eigen::Matrix3Xd& forces_N) override;
  const Eigen::VectorXd& mass_kg() const override { return mass_kg_; }
  const Eigen::VectorXd& inverseMass_per_kg() const override { return inverse_mass_per_kg_; }
  void constrainedPositions(double time_s, Eigen::Matrix3Xd& positions_m) const override;
  /// dF/dx and dF/dv of the springs, air damping and grasps; the wind's differential is left out (wind
  /// is weak and acts explicitly, through F0).
  void linearize(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                 double time_s) override;
  void forceDifferential(const Eigen::Matrix3Xd& dx_m, const Eigen::Matrix3Xd& dv_m_per_s,
                         Eigen::Matrix3Xd& df_N) override;
  void stiffnessProduct(const Eigen::Matrix3Xd& dx_m, Eigen::Matrix3Xd& df_N) override;
  void systemProduct(double step_s, const Eigen::Matrix3Xd& w, Eigen::Matrix3Xd& out) override;
  void systemDiagonalBlocks(double step_s, Eigen::Matrix<double, 6, Eigen::Dynamic>& blocks) override;
  /// 13 offsets: the diagonal (systemDiagonalBlocks) and each spring family both ways (minus the
  /// springs' blocks, plus the curvature term's, whose offsets are the same).
  bool systemGridMatrix(double step_s, GridBlockMatrix& matrix) override;

  /// The curvature bending term's energy, J (0 with bend springs).
  double bendingEnergy_J(const Eigen::Matrix3Xd& positions_m) const { return curvature_.energy_J(positions_m); }
  /// The curvature bending term (empty unless bend_model is curvature with a material's rigidity).
  const CurvatureBending& curvatureBending() const { return curvature_; }

  /// Springs one force evaluation computes (of the switched-on kinds).
  std::size_t springCount() const;
  /// Threads a force evaluation of this grid uses: options.threads from 4096 particles up, else 1.
  int threads() const override;

 private:
  /// Column-major N x 3: each coordinate contiguous (structure of arrays).
  using SoaField = Eigen::Matrix<double, Eigen::Dynamic, 3>;

  /// The switched-on families (zero stiffness and damping counts as off), in kStencilFamilies order.
  struct ActiveFamilies {
    std::array<StencilFamily, kStencilFamilies.size()> family{};
    int count = 0;
  };
  /// Row scratch arrays per thread: 3 for forces and differentials, 6 for the diagonal blocks (sized
  /// for the larger once, so no call reallocates).
  static constexpr int kRowScratchArrays = 6;

  ActiveFamilies activeFamilies() const;
  /// Sizes the per-thread row scratch (kRowScratchArrays grid rows per thread).
  void prepareRowScratch();
  /// This thread's row scratch (inside or outside a parallel region).
  double* threadRowScratch();
  /// True from the particle count where threads pay (src/core/parallel.h).
  bool parallel() const;
  /// Adds the curvature term's off-diagonal blocks (h^2 + h beta) Q_ij to the system matrix.
  void addCurvatureBlocks(double step_s, GridBlockMatrix& matrix) const;
  /// inputs_.grasps, less those on a particle a gripper holds (graspActs); the inputs' own vector when
  /// every grasp acts.
  const std::vector<Grasp>& actingGrasps();
  /// Adds the springs' differential for the change w in positions (times scale_x) and velocities (times
  /// scale_v) to out.
  void addSpringDifferential(const SoaField& w, double scale_x, double scale_v, SoaField& out);

  const ClothGrid& grid_;
  const SceneOptions& options_;
  const Eigen::VectorXd& mass_kg_;
  const ClothInputs& inputs_;
  Kinematics kinematics_;                ///< from options_ and inputs_, by refreshConstraints
  CurvatureBending curvature_;           ///< from options_, by refreshConstraints
  /// 0 on the particles kinematics_ holds (hooked pins, gripped particles) and outside an outline.
  Eigen::VectorXd inverse_mass_per_kg_;
  /// Per particle, 1 where a gripper holds it (empty while no gripper holds any), by refreshConstraints.
  std::vector<std::uint8_t> gripper_held_;
  std::array<double, kStencilFamilies.size()> rest_length_m_{};  ///< per family, from the rest grid
  /// Per family, with an outline: 1 at the first particle of each spring whose ends are both inside.
  std::array<std::vector<std::uint8_t>, kStencilFamilies.size()> present_;

  // Scratch, reused across calls (sized on first use).
  SoaField positions_, velocities_, result_, dx_;
  std::vector<Grasp> acting_grasps_;  ///< actingGrasps' list when a grasp does not act
  Eigen::MatrixXd row_scratch_;  ///< one column per thread: a few grid rows of per-spring values
  Eigen::Matrix<double, Eigen::Dynamic, 6> block_sums_, spring_blocks_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> diagonal_blocks_;
  // The linearisation (written by linearize), per switched-on family.
  SoaField linearized_positions_;
  ActiveFamilies linearized_families_;
  std::array<Eigen::VectorXd, kStencilFamilies.size()> inverse_length_, transverse_stiffness_;
  std::array<const double*, kStencilFamilies.size()> linearized_inverse_length_{}, linearized_transverse_{};
};

}  // namespace cloth_sim::core
