#include "bullet_cloth.h"

#include "bench_stats.h"

#include "cloth_sim/core/constants.h"

#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>
#include <BulletDynamics/ConstraintSolver/btSequentialImpulseConstraintSolver.h>
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace cloth_sim::bench {

namespace {

constexpr double kGravityZ_m_per_s2 = -9.81;
constexpr double kAirDensity_kg_per_m3 = 1.2;
/// Height of the fixed top edge, m (same as config/scenes/hanging.yaml).
constexpr double kTopEdgeZ_m = 1.5;
/// Largest particles per side accepted: keeps rows * cols far from int overflow in Bullet's node indices.
constexpr int kMaxParticlesPerSide = 4096;
/// Bending links join nodes this many apart along a row or a column (our "bend" springs).
constexpr int kBendingSpan = 2;
using core::kMillisecondsPerSecond;

void validate(const BulletClothSetup& s) {
  auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("BulletClothSetup: " + what);
  };
  require(s.rows >= 2 && s.rows <= kMaxParticlesPerSide, "rows must be in [2, 4096]");
  require(s.cols >= 2 && s.cols <= kMaxParticlesPerSide, "cols must be in [2, 4096]");
  require(std::isfinite(s.width_m) && s.width_m > 0, "width_m must be > 0");
  require(std::isfinite(s.height_m) && s.height_m > 0, "height_m must be > 0");
  require(std::isfinite(s.mass_kg) && s.mass_kg > 0, "mass_kg must be > 0");
  require(s.substeps >= 1, "substeps must be >= 1");
  require(s.position_iterations >= 1, "position_iterations must be >= 1");
  require(s.stretch_stiffness > 0 && s.stretch_stiffness <= 1, "stretch_stiffness must be in (0, 1]");
  require(s.damping >= 0 && s.damping <= 1, "damping must be in [0, 1]");
  require(s.frames >= 1, "frames must be >= 1");
  require(std::isfinite(s.frame_s) && s.frame_s > 0, "frame_s must be > 0");
}

/// Bullet's world and its collaborators. Members are destroyed in reverse order, so the world goes before the
/// solver, broadphase, dispatcher and configuration it points to.
struct BulletWorld {
  std::unique_ptr<btSoftBodyRigidBodyCollisionConfiguration> configuration =
      std::make_unique<btSoftBodyRigidBodyCollisionConfiguration>();
  std::unique_ptr<btCollisionDispatcher> dispatcher = std::make_unique<btCollisionDispatcher>(configuration.get());
  std::unique_ptr<btBroadphaseInterface> broadphase = std::make_unique<btDbvtBroadphase>();
  std::unique_ptr<btConstraintSolver> solver = std::make_unique<btSequentialImpulseConstraintSolver>();
  std::unique_ptr<btSoftRigidDynamicsWorld> world =
      std::make_unique<btSoftRigidDynamicsWorld>(dispatcher.get(), broadphase.get(), solver.get(), configuration.get());
};

/// Owns the cloth while it is in the world; removes it before deleting it.
class ClothInWorld {
 public:
  ClothInWorld(btSoftRigidDynamicsWorld& world, std::unique_ptr<btSoftBody> cloth)
      : world_(world), cloth_(std::move(cloth)) {
    world_.addSoftBody(cloth_.get());
  }
  ~ClothInWorld() { world_.removeSoftBody(cloth_.get()); }
  ClothInWorld(const ClothInWorld&) = delete;
  ClothInWorld& operator=(const ClothInWorld&) = delete;

  btSoftBody& cloth() { return *cloth_; }

 private:
  btSoftRigidDynamicsWorld& world_;
  std::unique_ptr<btSoftBody> cloth_;
};

std::unique_ptr<btSoftBody> createCloth(btSoftBodyWorldInfo& world_info, const BulletClothSetup& s) {
  // Row 0 is the top edge at y = 0, z = 1.5; rows run down -z (hanging) or along +y (dynamic, lying flat).
  const btVector3 top_left(btScalar(-0.5 * s.width_m), 0, btScalar(kTopEdgeZ_m));
  const btVector3 top_right(btScalar(0.5 * s.width_m), 0, btScalar(kTopEdgeZ_m));
  const btVector3 row_direction = s.dynamic ? btVector3(0, 1, 0) : btVector3(0, 0, -1);
  const btVector3 down = row_direction * btScalar(s.height_m);
  // CreatePatch puts node (ix, iy) at index iy * resx + ix, ix running corner00 -> corner10 and iy corner00 ->
  // corner01; so resx = cols along x and resy = rows gives our row * cols + col numbering.
  constexpr int kNoFixedCorners = 0;  // fixed after setTotalMass below
  constexpr bool kDiagonalLinks = true;
  std::unique_ptr<btSoftBody> cloth(btSoftBodyHelpers::CreatePatch(world_info, top_left, top_right, top_left + down,
                                                                   top_right + down, s.cols, s.rows, kNoFixedCorners,
                                                                   kDiagonalLinks));
  if (cloth == nullptr) throw std::runtime_error("btSoftBodyHelpers::CreatePatch failed");

  // CreatePatch made its links with m_materials[0]; they pick up the new stiffness when Bullet next refreshes its
  // runtime constants (setTotalMass and appendLink both ask for that).
  cloth->m_materials[0]->m_kLST = btScalar(s.stretch_stiffness);
  // Bending links, built here instead of generateBendingConstraints(2): that builds an n x n distance table (1.1 GB
  // at 128 x 128 nodes, int overflow at 256 x 256).
  btSoftBody::Material* bending = cloth->appendMaterial();
  bending->m_kLST = btScalar(s.stretch_stiffness);
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      const int i = r * s.cols + c;
      if (c + kBendingSpan < s.cols) cloth->appendLink(i, i + kBendingSpan, bending);
      if (r + kBendingSpan < s.rows) cloth->appendLink(i, i + kBendingSpan * s.cols, bending);
    }
  }
  // The links are now in build order: row-major, all structural and diagonal links before all bending links. With
  // one Gauss-Seidel pass that fixed sweep order injects energy and the cloth blows up (64 x 64 and up at 10+
  // substeps); Bullet's own demos shuffle, as here. The shuffle is deterministic (fixed seed inside Bullet).
  cloth->randomizeConstraints();

  // Bullet scales node velocities by (1 - kDP) after every internal substep, so the same kDP damps harder with
  // more substeps (a decay rate of about kDP * substeps / frame_s per second).
  cloth->m_cfg.kDP = btScalar(s.damping);
  cloth->m_cfg.piterations = s.position_iterations;
  // Every node gets mass_kg / (rows * cols); the two corners are then pinned (inverse mass 0), as in our grid.
  cloth->setTotalMass(btScalar(s.mass_kg));
  cloth->setMass(0, 0);
  cloth->setMass(s.cols - 1, 0);
  // setMass leaves m_bUpdateRtCst set, so the first step recomputes every link's rest length from the node
  // positions, which are still the grid as built. Nothing sets it again during the run; if something did, the rest
  // lengths would be reset to the stretched shape.
  return cloth;
}

/// One grid-neighbour pair and its rest length, m.
struct StructuralPair {
  int first = 0, second = 0;
  double rest_m = 0;
};

std::vector<StructuralPair> structuralPairs(const BulletClothSetup& s) {
  const double dx_m = s.width_m / (s.cols - 1);
  const double dy_m = s.height_m / (s.rows - 1);
  std::vector<StructuralPair> pairs;
  pairs.reserve(2 * static_cast<std::size_t>(s.rows) * static_cast<std::size_t>(s.cols));
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.cols; ++c) {
      const int i = r * s.cols + c;
      if (c + 1 < s.cols) pairs.push_back({i, i + 1, dx_m});
      if (r + 1 < s.rows) pairs.push_back({i, i + s.cols, dy_m});
    }
  }
  return pairs;
}

bool allNodesFinite(const btSoftBody& cloth) {
  for (int i = 0; i < cloth.m_nodes.size(); ++i) {
    const btVector3& x = cloth.m_nodes[i].m_x;
    if (!std::isfinite(x.x()) || !std::isfinite(x.y()) || !std::isfinite(x.z())) return false;
  }
  return true;
}

double maxStructuralStrain(const btSoftBody& cloth, const std::vector<StructuralPair>& pairs) {
  double max_strain = -1.0;  // a link cannot shrink below zero length, so any real strain beats this
  for (const StructuralPair& p : pairs) {
    const double length_m = static_cast<double>((cloth.m_nodes[p.second].m_x - cloth.m_nodes[p.first].m_x).length());
    max_strain = std::max(max_strain, (length_m - p.rest_m) / p.rest_m);
  }
  return max_strain;
}

}  // namespace

BulletClothResult runBulletCloth(const BulletClothSetup& setup) {
  validate(setup);
  BulletWorld bullet;
  bullet.world->setGravity(btVector3(0, 0, btScalar(kGravityZ_m_per_s2)));
  // The soft-body solver reads gravity and air from the world info, not from the rigid-body world.
  btSoftBodyWorldInfo& world_info = bullet.world->getWorldInfo();
  world_info.m_gravity.setValue(0, 0, btScalar(kGravityZ_m_per_s2));
  world_info.air_density = btScalar(kAirDensity_kg_per_m3);
  world_info.m_sparsesdf.Initialize();

  ClothInWorld cloth_in_world(*bullet.world, createCloth(world_info, setup));
  btSoftBody& cloth = cloth_in_world.cloth();
  const std::vector<StructuralPair> pairs = structuralPairs(setup);

  BulletClothResult result;
  result.links = cloth.m_links.size();
  result.max_strain = std::max(0.0, maxStructuralStrain(cloth, pairs));

  const btScalar frame_s = btScalar(setup.frame_s);
  // Divided in btScalar (float), not double: Bullet counts substeps as int(accumulated / substep_s), and a substep
  // rounded from double made that 9 of 10 on the first frame (0.02 s), always one substep short per run.
  const btScalar substep_s = frame_s / btScalar(setup.substeps);
  std::vector<double> frame_ms;
  frame_ms.reserve(static_cast<std::size_t>(setup.frames));
  for (int frame = 0; frame < setup.frames; ++frame) {
    const auto start = std::chrono::steady_clock::now();
    bullet.world->stepSimulation(frame_s, setup.substeps, substep_s);
    const auto stop = std::chrono::steady_clock::now();
    frame_ms.push_back(std::chrono::duration<double>(stop - start).count() * kMillisecondsPerSecond);
    // Bullet stops simulating a body whose bounding box passes 1e6 m (DISABLE_SIMULATION): its nodes freeze and
    // later steps cost nothing, so that counts as a blow-up too.
    if (!allNodesFinite(cloth) || cloth.getActivationState() == DISABLE_SIMULATION) {
      result.finite = false;
      break;  // strain and timings after a blow-up mean nothing
    }
    result.max_strain = std::max(result.max_strain, maxStructuralStrain(cloth, pairs));
  }

  const FrameTimings timings = summarizeFrameTimes(frame_ms);
  result.ms_per_frame = timings.mean_ms.value_or(0.0);
  result.p50_ms = timings.p50_ms.value_or(0.0);
  result.p99_ms = timings.p99_ms.value_or(0.0);
  result.rss_mb = peakRssMb();
  return result;
}

}  // namespace cloth_sim::bench
