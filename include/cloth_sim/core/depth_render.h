// A CPU depth renderer for simulated cameras: the cloth's triangles and the scene's colliders seen
// through a pinhole camera, with a z-buffer. ROS-free and deterministic (same inputs, same bits).
//
// Conventions (REP 103 optical frame, as CameraInfo and depth_image_proc use them): z forward along the
// optical axis, x right, y down; pixel (u, v) = (column, row), integer coordinates at pixel centres;
// depth is the z coordinate of the surface point seen (not the distance along the ray), metres.
//
// Triangles: clipped at z = min_range, projected (u = fx x / z + cx, v = fy y / z + cy), and a pixel centre
// inside a triangle (both windings: both sides of the cloth are seen) gets z from the barycentric
// interpolation of 1 / z, which is linear in the image, so the depth is exact for the plane of the
// triangle (perspective-correct). The nearest surface wins each pixel. Colliders are ray-cast per
// pixel analytically (planes, spheres, axis-aligned boxes) into the same z-buffer.
#pragma once

#include "cloth_sim/core/camera.h"
#include "cloth_sim/core/contact.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

namespace cloth_sim::core {

/// The intrinsics and range of one camera (a CameraOptions without its names and noise).
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx_px = 1.0;
  double fy_px = 1.0;
  double cx_px = 0.0;
  double cy_px = 0.0;
  double min_range_m = 0.0;
  double max_range_m = 0.0;

  static PinholeCamera from(const CameraOptions& options);
};

/// What a camera sees, row-major (index v * width + u).
struct DepthFrame {
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;     ///< z of the surface seen, m; NaN where nothing is seen in range
  std::vector<std::uint8_t> mask;  ///< kClothMask where the cloth is the surface seen, else 0
  std::vector<std::uint8_t> rgb;   ///< 3 bytes per pixel (R, G, B), shaded; empty unless asked for

  static constexpr std::uint8_t kClothMask = 255;
};

/// The scene as one image sees it: the cloth's mesh and the colliders at one instant.
struct RenderScene {
  const Eigen::Matrix3Xd* positions_m = nullptr;  ///< 3 x N, world frame
  const std::vector<int>* triangles = nullptr;     ///< three particle indices each (ClothGrid::triangles)
  const Eigen::Matrix3Xf* colors = nullptr;        ///< 3 x N, RGB in [0, 1]; null: white
  const ColliderSet* colliders = nullptr;          ///< null: none
  double time_s = 0.0;                             ///< where moving spheres are
  /// Colliders are drawn this far inside their surfaces, m (colliderInset_m), as rviz draws them inset:
  /// a cloth resting on a collider lies up to the contact band inside it, and would show it through.
  double collider_inset_m = 0.0;
};

/// The inset for a scene's contact options: twice the contact band (particles lie up to one band deep,
/// and the triangles between them a little more over an edge), and at least 1 mm.
double colliderInset_m(const ContactOptions& contact);

/// Renders into a DepthFrame; keeps its scratch buffers between calls (one renderer per camera).
class DepthRenderer {
 public:
  /// world_from_optical: the camera's optical frame in the world frame (a rigid transform).
  /// with_color: fill frame->rgb as well (the cloth's colours and a grey for colliders, shaded by the
  /// angle between the surface and the ray, so folds show).
  void render(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical, const RenderScene& scene,
              bool with_color, DepthFrame* frame);

 private:
  void castColliders(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical,
                     const ColliderSet& colliders, double time_s, double inset_m, bool with_color,
                     DepthFrame* frame);
  void rasterizeCloth(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical,
                      const RenderScene& scene, bool with_color, DepthFrame* frame);

  Eigen::Matrix3Xd optical_positions_m_;  ///< the cloth's vertices in the optical frame
  Eigen::Matrix3Xd projected_;            ///< per vertex: u, v (pixels), 1 / z (1/m)
  std::vector<Eigen::Vector3f> colors_;   ///< per vertex, RGB in [0, 1]
};

/// The optical frame (z forward, x right, y down) of a camera at eye_m looking at target_m with up_axis
/// pointing up in the image, as world_from_optical. eye and target must differ and up must not be parallel
/// to the view direction.
Eigen::Isometry3d opticalLookAt(const Eigen::Vector3d& eye_m, const Eigen::Vector3d& target_m,
                                const Eigen::Vector3d& up_axis);

/// Axial (depth) noise of a structured-light sensor at depth z, m: sigma_z = 0.0012 + 0.0019 (z - 0.4)^2,
/// from C. V. Nguyen, S. Izadi and D. Lovell, "Modeling Kinect Sensor Noise for Improved 3D Reconstruction
/// and Tracking", 3DIMPVT 2012 (fitted for 0.5 to 3 m at surface angles of 10 to 60 degrees).
double kinectDepthSigma_m(double depth_m);

/// Adds Gaussian noise of kinectDepthSigma_m to every finite depth; a value pushed outside
/// [min_range, max_range] becomes NaN. Each pixel's draw depends only on (seed, frame_number, pixel), by
/// a counter-based generator, so an image's noise is reproducible whatever rendered before it.
void addKinectNoise(std::uint32_t seed, std::uint64_t frame_number, const PinholeCamera& camera, DepthFrame* frame);

}  // namespace cloth_sim::core
