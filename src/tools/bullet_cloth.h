// Reference cloth run on Bullet's soft bodies (btSoftBody, position-based link solver), for comparing speed and
// stretch against our simulator on the same scene. Self-contained: no ROS and nothing from the rest of cloth_sim.
// Link with -lBulletSoftBody -lBulletDynamics -lBulletCollision -lLinearMath (Debian package libbullet-dev).
#pragma once

namespace cloth_sim::bench {

/// One Bullet cloth run. The patch spans width_m along +x and height_m along -z (hanging) or +y (dynamic), with
/// its top-left corner at (-width_m / 2, 0, 1.5); particle (row, col) is row * cols + col, row 0 the top edge.
struct BulletClothSetup {
  int rows = 20, cols = 20;  ///< particles per side (each >= 2)
  double width_m = 1.0, height_m = 1.0, mass_kg = 0.5;
  int substeps = 1;  ///< Bullet internal substeps per frame: stepSimulation(frame_s, substeps, frame_s / substeps)
  int position_iterations = 1;     ///< btSoftBody::m_cfg.piterations
  double stretch_stiffness = 0.9;  ///< m_kLST of the link materials, in (0, 1]
  double damping = 0.01;           ///< m_cfg.kDP, in [0, 1]: applied once per internal substep
  int frames = 100;
  double frame_s = 0.02;
  /// false: hangs in the x-z plane from its two top corners (only the top edge sags: a near-static case).
  /// true: starts horizontal in the x-y plane at z = 1.5 with the two corners of the row-0 edge fixed, so it swings
  /// down about that edge.
  bool dynamic = false;
};

struct BulletClothResult {
  double ms_per_frame = 0;  ///< mean wall time of one stepSimulation call (steady_clock), ms
  double p50_ms = 0, p99_ms = 0;
  /// Largest (|d| - L) / L over the structural (grid-neighbour) pairs, from node positions after every frame.
  double max_strain = 0;
  /// Every node position finite after every frame, and Bullet still simulating the body (it disables one whose
  /// bounding box passes 1e6 m). The run stops at the first frame that fails, so the timings then cover only the
  /// frames up to it.
  bool finite = true;
  double rss_mb = 0;  ///< peak RSS of the whole process (getrusage ru_maxrss / 1024), MiB
  int links = 0;      ///< links in the soft body: structural + one diagonal per quad + bending (two apart)
};

/// Builds the scene, runs setup.frames frames and tears it down. Throws std::invalid_argument on a bad setup.
BulletClothResult runBulletCloth(const BulletClothSetup& setup);

}  // namespace cloth_sim::bench
