#include "cloth_sim/core/preconditioner.h"

#include "cloth_sim/core/multigrid.h"

#include "parallel.h"

#include <cmath>

namespace cloth_sim::core {

const std::vector<PreconditionerKind>& allPreconditionerKinds() {
  static const std::vector<PreconditionerKind> kinds{PreconditionerKind::kBlockJacobi,
                                                     PreconditionerKind::kMultigrid};
  return kinds;
}

const char* preconditionerName(PreconditionerKind kind) {
  switch (kind) {
    case PreconditionerKind::kBlockJacobi:
      return "block_jacobi";
    case PreconditionerKind::kMultigrid:
      return "multigrid";
  }
  return "unknown";
}

bool parsePreconditionerName(const std::string& name, PreconditionerKind* kind) {
  for (PreconditionerKind candidate : allPreconditionerKinds()) {
    if (name == preconditionerName(candidate)) {
      *kind = candidate;
      return true;
    }
  }
  return false;
}

std::string preconditionerNameList() {
  std::string names;
  for (PreconditionerKind kind : allPreconditionerKinds()) {
    names += (names.empty() ? "" : ", ") + std::string(preconditionerName(kind));
  }
  return names;
}

void invertSymmetricBlock(double* b) {
  const double xx = b[0], yy = b[1], zz = b[2], xy = b[3], xz = b[4], yz = b[5];
  const double c_xx = yy * zz - yz * yz;
  const double c_xy = xz * yz - xy * zz;
  const double c_xz = xy * yz - xz * yy;
  const double det = xx * c_xx + xy * c_xy + xz * c_xz;
  if (!(det > 0.0) || !std::isfinite(det)) {
    b[0] = 1.0 / xx;
    b[1] = 1.0 / yy;
    b[2] = 1.0 / zz;
    b[3] = b[4] = b[5] = 0.0;
    return;
  }
  const double inv = 1.0 / det;
  b[0] = c_xx * inv;
  b[1] = (xx * zz - xz * xz) * inv;
  b[2] = (xx * yy - xy * xy) * inv;
  b[3] = c_xy * inv;
  b[4] = c_xz * inv;
  b[5] = (xy * xz - xx * yz) * inv;
}

void BlockJacobiPreconditioner::setup(Dynamics& dynamics, double step_s, const Eigen::VectorXd& free) {
  free_ = free;
  threads_ = dynamics.threads();
  dynamics.systemDiagonalBlocks(step_s, blocks_);
  forEachChunk(blocks_.cols(), threads_, [&](Eigen::Index begin, Eigen::Index end) {
    for (Eigen::Index i = begin; i < end; ++i) invertSymmetricBlock(blocks_.col(i).data());
  });
}

void BlockJacobiPreconditioner::applyRange(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z, Eigen::Index begin,
                                           Eigen::Index end) const {
  for (Eigen::Index i = begin; i < end; ++i) {
    const double* b = blocks_.col(i).data();
    const double x = r(0, i), y = r(1, i), w = r(2, i);
    const double keep = free_[i];
    z(0, i) = keep * (b[0] * x + b[3] * y + b[4] * w);
    z(1, i) = keep * (b[3] * x + b[1] * y + b[5] * w);
    z(2, i) = keep * (b[4] * x + b[5] * y + b[2] * w);
  }
}

void BlockJacobiPreconditioner::apply(const Eigen::Matrix3Xd& r, Eigen::Matrix3Xd& z) {
  z.resize(3, r.cols());
  forEachChunk(r.cols(), threads_, [&](Eigen::Index begin, Eigen::Index end) { applyRange(r, z, begin, end); });
}

std::unique_ptr<Preconditioner> makePreconditioner(PreconditionerKind kind) {
  switch (kind) {
    case PreconditionerKind::kBlockJacobi:
      return std::make_unique<BlockJacobiPreconditioner>();
    case PreconditionerKind::kMultigrid:
      return std::make_unique<MultigridPreconditioner>();
  }
  return nullptr;
}

}  // namespace cloth_sim::core
