#include "cloth_sim/core/force_model.h"

#include "parallel.h"

#include <algorithm>
#include <cmath>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace cloth_sim::core {

namespace {

/// The rows [begin, end) this thread works on inside a parallel region (all rows outside one).
struct RowBand {
  int begin = 0;
  int end = 0;
};

RowBand threadBand(int rows) {
#ifdef _OPENMP
  const int threads = omp_get_num_threads();
  const int thread = omp_get_thread_num();
#else
  const int threads = 1;
  const int thread = 0;
#endif
  return {static_cast<int>(static_cast<long>(rows) * thread / threads),
          static_cast<int>(static_cast<long>(rows) * (thread + 1) / threads)};
}

template <typename SoaField>
ConstField constView(const SoaField& field) {
  return {field.col(0).data(), field.col(1).data(), field.col(2).data()};
}

template <typename SoaField>
Field view(SoaField& field) {
  return {field.col(0).data(), field.col(1).data(), field.col(2).data()};
}

}  // namespace

ClothForceModel::ClothForceModel(const ClothGrid& grid, const SceneOptions& options, const Eigen::VectorXd& mass_kg,
                                 const ClothInputs& inputs)
    : grid_(grid), options_(options), mass_kg_(mass_kg), inputs_(inputs) {
  for (std::size_t f = 0; f < kStencilFamilies.size(); ++f) {
    const StencilFamilyLayout& layout = kStencilFamilies[f];
    const int first = grid_.index(0, std::max(0, -layout.dc));
    const int second = grid_.index(layout.dr, std::max(0, -layout.dc) + layout.dc);
    const bool exists = layout.dr < grid_.rows && std::max(0, layout.dc) < grid_.cols;
    rest_length_m_[f] =
        exists ? (grid_.rest_positions_m.col(second) - grid_.rest_positions_m.col(first)).norm() : 0.0;
    if (grid_.hasOutline()) {  // a spring exists where both its ends are inside the outline
      present_[f].assign(static_cast<std::size_t>(grid_.particleCount()), 0);
      const int offset = kStencilFamilies[f].dr * grid_.cols + kStencilFamilies[f].dc;
      for (int p = 0; p < grid_.particleCount(); ++p) {
        const int q = p + offset;
        if (q >= 0 && q < grid_.particleCount() && grid_.isActive(p) && grid_.isActive(q)) present_[f][p] = 1;
      }
    }
  }
  refreshConstraints();
}

bool ClothForceModel::parallel() const { return runsInParallel(grid_.particleCount(), options_.threads); }

ClothForceModel::ActiveFamilies ClothForceModel::activeFamilies() const {
  ActiveFamilies active;
  for (std::size_t f = 0; f < kStencilFamilies.size(); ++f) {
    const SpringOptions& spring = options_.springs[kStencilFamilies[f].kind];
    if (!spring.enabled || (spring.stiffness_N_per_m == 0.0 && spring.damping_N_s_per_m == 0.0)) continue;
    active.family[active.count++] = {kStencilFamilies[f].dr, kStencilFamilies[f].dc, rest_length_m_[f],
                                     spring.stiffness_N_per_m, spring.damping_N_s_per_m,
                                     springCompressionCap_N(spring, rest_length_m_[f]),
                                     grid_.hasOutline() ? present_[f].data() : nullptr};
  }
  return active;
}

void ClothForceModel::prepareRowScratch() {
  row_scratch_.resize(static_cast<Eigen::Index>(kRowScratchArrays) * grid_.cols, threads());
}

double* ClothForceModel::threadRowScratch() {
#ifdef _OPENMP
  return row_scratch_.col(omp_get_thread_num()).data();
#else
  return row_scratch_.data();
#endif
}

void ClothForceModel::refreshConstraints() {
  kinematics_.setScene(options_, inputs_);
  buildCurvatureBending(options_, &curvature_, grid_.active);
  inverse_mass_per_kg_ = mass_kg_.cwiseInverse();
  // Outside an outline a particle never moves: held where it started, like a pin nobody moves.
  for (int p = 0; p < grid_.particleCount(); ++p) {
    if (!grid_.isActive(p)) inverse_mass_per_kg_[p] = 0.0;
  }
  kinematics_.maskConstrained(inverse_mass_per_kg_);
  gripper_held_.clear();
  for (const Gripper& gripper : inputs_.grippers) {
    if (gripper.particles.empty()) continue;
    gripper_held_.resize(static_cast<std::size_t>(grid_.particleCount()), 0);
    for (const int particle : gripper.particles) gripper_held_[static_cast<std::size_t>(particle)] = 1;
  }
}

const std::vector<Grasp>& ClothForceModel::actingGrasps() {
  if (std::all_of(inputs_.grasps.begin(), inputs_.grasps.end(), [this](const Grasp& g) { return graspActs(g); })) {
    return inputs_.grasps;
  }
  acting_grasps_.clear();
  for (const Grasp& grasp : inputs_.grasps) {
    if (graspActs(grasp)) acting_grasps_.push_back(grasp);
  }
  return acting_grasps_;
}

void ClothForceModel::constrainedPositions(double time_s, Eigen::Matrix3Xd& positions_m) const {
  kinematics_.prescribedPositions(time_s, positions_m);
}

std::size_t ClothForceModel::springCount() const {
  std::size_t count = 0;
  for (int k = 0; k < kSpringKindCount; ++k) {
    const SpringOptions& spring = options_.springs[k];
    // As activeFamilies: a kind with neither stiffness nor damping is skipped, so it is not counted.
    if (spring.enabled && (spring.stiffness_N_per_m != 0.0 || spring.damping_N_s_per_m != 0.0)) {
      count += grid_.springs[k].size();
    }
  }
  return count;
}

int ClothForceModel::threads() const { return parallel() ? options_.threads : 1; }

void ClothForceModel::forces(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd& velocities_m_per_s,
                             double time_s, Eigen::Matrix3Xd& forces_N) {
  const int rows = grid_.rows;
  const int cols = grid_.cols;
  positions_ = positions_m.transpose();
  velocities_ = velocities_m_per_s.transpose();
  result_.setZero(positions_m.cols(), 3);
  const ActiveFamilies springs = activeFamilies();
  prepareRowScratch();
#pragma omp parallel num_threads(threads()) if (parallel())
  {
    const RowBand band = threadBand(rows);
    stencilAccumulateSpringForces(rows, cols, springs.family.data(), springs.count, constView(positions_),
                                  constView(velocities_), view(result_), threadRowScratch(), band.begin, band.end);
  }
  forces_N = result_.transpose();
  curvature_.addForces(positions_m, velocities_m_per_s, forces_N);
  const SceneOptions& o = options_;
  if (!o.gravity_m_per_s2.isZero()) accumulateGravity(mass_kg_, o.gravity_m_per_s2, forces_N);
  const double air_damping_N_s_per_m = airDampingPerParticle_N_s_per_m(o);
  if (air_damping_N_s_per_m > 0.0) accumulateAirDamping(air_damping_N_s_per_m, velocities_m_per_s, forces_N);
  if (o.wind_enabled) {
    WindOptions wind = o.wind;
    wind.velocity_m_per_s = inputs_.wind_m_per_s;
    wind.paper_coefficient_N_s_per_m = paperWindCoefficientPerTriangle_N_s_per_m(o);
    accumulateWindForces(grid_.triangles, wind, windVelocityAt(wind, time_s), positions_m, velocities_m_per_s,
                         forces_N);
  }
  if (!inputs_.grasps.empty()) accumulateGraspForces(actingGrasps(), positions_m, velocities_m_per_s, forces_N);
}

void ClothForceModel::linearize(const Eigen::Matrix3Xd& positions_m, const Eigen::Matrix3Xd&, double) {
  const int rows = grid_.rows;
  const int cols = grid_.cols;
  const Eigen::Index count = positions_m.cols();
  linearized_positions_ = positions_m.transpose();
  linearized_families_ = activeFamilies();
  const ActiveFamilies& springs = linearized_families_;
  for (int f = 0; f < springs.count; ++f) {
    inverse_length_[f].resize(count);
    transverse_stiffness_[f].resize(count);
    linearized_inverse_length_[f] = inverse_length_[f].data();
    linearized_transverse_[f] = transverse_stiffness_[f].data();
  }
#pragma omp parallel num_threads(threads()) if (parallel())
  {
    const RowBand band = threadBand(rows);
    for (int f = 0; f < springs.count; ++f) {
      stencilLinearize(rows, cols, springs.family[f], constView(linearized_positions_), inverse_length_[f].data(),
                       transverse_stiffness_[f].data(), band.begin, band.end);
    }
  }
}

void ClothForceModel::addSpringDifferential(const SoaField& w, double scale_x, double scale_v, SoaField& out) {
  const int rows = grid_.rows;
  const int cols = grid_.cols;
  const ActiveFamilies& springs = linearized_families_;
  prepareRowScratch();
#pragma omp parallel num_threads(threads()) if (parallel())
  {
    const RowBand band = threadBand(rows);
    stencilAccumulateDifferential(rows, cols, springs.family.data(), springs.count, constView(linearized_positions_),
                                  linearized_inverse_length_.data(), linearized_transverse_.data(), constView(w),
                                  scale_x, scale_v, view(out), threadRowScratch(), band.begin, band.end);
  }
}

void ClothForceModel::forceDifferential(const Eigen::Matrix3Xd& dx_m, const Eigen::Matrix3Xd& dv_m_per_s,
                                        Eigen::Matrix3Xd& df_N) {
  result_.setZero(dx_m.cols(), 3);
  dx_ = dx_m.transpose();
  addSpringDifferential(dx_, 1.0, 0.0, result_);
  dx_ = dv_m_per_s.transpose();
  addSpringDifferential(dx_, 0.0, 1.0, result_);
  df_N = result_.transpose();
  curvature_.addDifferential(dx_m, dv_m_per_s, 1.0, 1.0, df_N);
  df_N -= airDampingPerParticle_N_s_per_m(options_) * dv_m_per_s;
  for (const Grasp& grasp : actingGrasps()) {
    df_N.col(grasp.particle) -=
        grasp.stiffness_N_per_m * dx_m.col(grasp.particle) + grasp.damping_N_s_per_m * dv_m_per_s.col(grasp.particle);
  }
}

void ClothForceModel::stiffnessProduct(const Eigen::Matrix3Xd& dx_m, Eigen::Matrix3Xd& df_N) {
  result_.setZero(dx_m.cols(), 3);
  dx_ = dx_m.transpose();
  addSpringDifferential(dx_, 1.0, 0.0, result_);
  df_N = result_.transpose();
  curvature_.addDifferential(dx_m, dx_m, 1.0, 0.0, df_N);
  for (const Grasp& grasp : actingGrasps()) df_N.col(grasp.particle) -= grasp.stiffness_N_per_m * dx_m.col(grasp.particle);
}

void ClothForceModel::systemProduct(double step_s, const Eigen::Matrix3Xd& w, Eigen::Matrix3Xd& out) {
  const double h = step_s;
  dx_ = w.transpose();
  result_.setZero(w.cols(), 3);
  addSpringDifferential(dx_, h * h, h, result_);
  // (M + h c_air) w - springs' dF; the grasps' springs and dampers join on their particles' diagonal.
  out = w * (mass_kg_.array() + h * airDampingPerParticle_N_s_per_m(options_)).matrix().asDiagonal();
  out -= result_.transpose();
  // The curvature term's differential is -Q (dx + beta dv): with dx = h^2 w and dv = h w it adds.
  curvature_.addDifferential(w, w, -h * h, -h, out);
  for (const Grasp& grasp : actingGrasps()) {
    out.col(grasp.particle) += (h * h * grasp.stiffness_N_per_m + h * grasp.damping_N_s_per_m) * w.col(grasp.particle);
  }
}

void ClothForceModel::systemDiagonalBlocks(double step_s, Eigen::Matrix<double, 6, Eigen::Dynamic>& blocks) {
  const double h = step_s;
  const int rows = grid_.rows;
  const int cols = grid_.cols;
  block_sums_.setZero(grid_.particleCount(), 6);
  double* sums[6];
  for (int e = 0; e < 6; ++e) sums[e] = block_sums_.col(e).data();
  const ActiveFamilies& springs = linearized_families_;
  prepareRowScratch();
#pragma omp parallel num_threads(threads()) if (parallel())
  {
    const RowBand band = threadBand(rows);
    stencilAccumulateBlocks(rows, cols, springs.family.data(), springs.count, constView(linearized_positions_),
                            linearized_inverse_length_.data(), linearized_transverse_.data(), h * h, h, sums,
                            threadRowScratch(), band.begin, band.end);
  }
  blocks = block_sums_.transpose();
  blocks.topRows<3>().rowwise() += (mass_kg_.array() + h * airDampingPerParticle_N_s_per_m(options_)).matrix().transpose();
  if (!curvature_.empty()) {
    const Eigen::VectorXd diagonal = curvature_.hessian().diagonal() * (h * h + h * curvature_.damping_s());
    blocks.topRows<3>().rowwise() += diagonal.transpose();
  }
  for (const Grasp& grasp : actingGrasps()) {
    blocks.col(grasp.particle).head<3>().array() += h * h * grasp.stiffness_N_per_m + h * grasp.damping_N_s_per_m;
  }
}

bool ClothForceModel::systemGridMatrix(double step_s, GridBlockMatrix& matrix) {
  const double h = step_s;
  const int rows = grid_.rows;
  const int cols = grid_.cols;
  const int count = grid_.particleCount();
  std::vector<GridOffset> offsets{{0, 0}};
  for (const StencilFamilyLayout& layout : kStencilFamilies) {
    offsets.push_back({layout.dr, layout.dc});
    offsets.push_back({-layout.dr, -layout.dc});
  }
  matrix.reset(rows, cols, offsets);
  systemDiagonalBlocks(h, diagonal_blocks_);
  const int diagonal = matrix.diagonalIndex();
  forEachChunk(count, threads(), [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index p = begin; p < end; ++p) {
      std::copy_n(diagonal_blocks_.col(p).data(), GridBlockMatrix::kBlockEntries, matrix.block(static_cast<int>(p), diagonal));
    }
  });
  // Off the diagonal, minus each spring's block, at both its ends (the matrix is symmetric).
  spring_blocks_.resize(count, 6);
  double* spring[6];
  for (int e = 0; e < 6; ++e) spring[e] = spring_blocks_.col(e).data();
  const ActiveFamilies& springs = linearized_families_;
  for (int f = 0; f < springs.count; ++f) {
    const StencilFamily& family = springs.family[f];
#pragma omp parallel num_threads(threads()) if (parallel())
    {
      const RowBand band = threadBand(rows);
      stencilSpringBlocks(rows, cols, family, constView(linearized_positions_), inverse_length_[f].data(),
                          transverse_stiffness_[f].data(), h * h, h, spring, band.begin, band.end);
    }
    const int forward = matrix.offsetIndex(family.dr, family.dc);
    const int backward = matrix.offsetIndex(-family.dr, -family.dc);
    const int offset = family.offset(cols);
    forEachChunk(count, threads(), [&](Eigen::Index begin, Eigen::Index end) {
      for (Eigen::Index p = begin; p < end; ++p) {
        const int r = static_cast<int>(p) / cols;
        const int c = static_cast<int>(p) % cols;
        if (r + family.dr >= rows || c + family.dc < 0 || c + family.dc >= cols) continue;
        double* ahead = matrix.block(static_cast<int>(p), forward);
        double* behind = matrix.block(static_cast<int>(p) + offset, backward);
        for (int e = 0; e < GridBlockMatrix::kBlockEntries; ++e) ahead[e] = behind[e] = -spring[e][p];
      }
    });
  }
  addCurvatureBlocks(h, matrix);
  return true;
}

void ClothForceModel::addCurvatureBlocks(double step_s, GridBlockMatrix& matrix) const {
  if (curvature_.empty()) return;
  // Q couples the coordinates only with themselves: (h^2 + h beta) Q_ij on the xx, yy and zz entries.
  const double scale = step_s * step_s + step_s * curvature_.damping_s();
  const int cols = grid_.cols;
  const CurvatureBending::Hessian& q = curvature_.hessian();
  for (int row = 0; row < q.outerSize(); ++row) {
    for (CurvatureBending::Hessian::InnerIterator it(q, row); it; ++it) {
      const int column = static_cast<int>(it.col());
      if (column == row) continue;  // in systemDiagonalBlocks
      const int offset = matrix.offsetIndex(column / cols - row / cols, column % cols - row % cols);
      double* block = matrix.block(row, offset);
      for (int e = 0; e < 3; ++e) block[e] += scale * it.value();
    }
  }
}

}  // namespace cloth_sim::core
