// The depth renderer against closed forms: a plane's depth along every pixel's ray, the pixel count of a
// projected rectangle, a fold's hidden layer, colliders, ranges, noise statistics and determinism.
#include "cloth_sim/core/constants.h"
#include "cloth_sim/core/depth_render.h"
#include "cloth_sim/core/grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <tuple>

namespace cloth_sim::core {
namespace {

constexpr double kDepthTolerance_m = 1e-3;  // the 1 mm

PinholeCamera vgaCamera() {
  CameraOptions options;  // 640 x 480, fx = fy = 525, centre (319.5, 239.5), 0.3 to 10 m
  return PinholeCamera::from(options);
}

/// The camera 2 m in front of the default cloth (x in [-0.5, 0.5], z in [0.5, 1.5], y = 0), level,
/// looking along +y at the cloth's centre.
Eigen::Isometry3d cameraTwoMetresBefore() {
  return opticalLookAt({0.0, -2.0, 1.0}, {0.0, 0.0, 1.0}, Eigen::Vector3d::UnitZ());
}

Eigen::Vector3d pixelRay(const PinholeCamera& camera, int u, int v) {
  return {(u - camera.cx_px) / camera.fx_px, (v - camera.cy_px) / camera.fy_px, 1.0};
}

std::size_t pixelIndex(const DepthFrame& frame, int u, int v) { return static_cast<std::size_t>(v) * frame.width + u; }

/// A flat 1 m x 1 m cloth centred at (0, 0, 1), turned by yaw_rad about the vertical through its centre.
ClothGrid flatCloth(int side, double yaw_rad) {
  const Eigen::Vector3d u_axis(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  return buildClothGrid(side, side, 1.0, 1.0, Eigen::Vector3d(0.0, 0.0, 1.5) - 0.5 * u_axis, u_axis,
                        Eigen::Vector3d(0.0, 0.0, -1.0));
}

DepthFrame renderCloth(const PinholeCamera& camera, const Eigen::Isometry3d& pose, const Eigen::Matrix3Xd& positions,
                       const std::vector<int>& triangles, const ColliderSet* colliders = nullptr,
                       bool with_color = false, const Eigen::Matrix3Xf* colors = nullptr) {
  RenderScene scene;
  scene.positions_m = &positions;
  scene.triangles = &triangles;
  scene.colors = colors;
  scene.colliders = colliders;
  DepthRenderer renderer;
  DepthFrame frame;
  renderer.render(camera, pose, scene, with_color, &frame);
  return frame;
}

/// Area (pixels^2) and perimeter (pixels) of the polygon the corners project to, in order.
void projectedPolygon(const PinholeCamera& camera, const Eigen::Isometry3d& pose,
                      const std::vector<Eigen::Vector3d>& corners_m, double* area_px2, double* perimeter_px) {
  std::vector<Eigen::Vector2d> image;
  for (const Eigen::Vector3d& corner : corners_m) {
    const Eigen::Vector3d p = pose.inverse() * corner;
    image.emplace_back(camera.fx_px * p.x() / p.z() + camera.cx_px, camera.fy_px * p.y() / p.z() + camera.cy_px);
  }
  double twice_area = 0.0;
  *perimeter_px = 0.0;
  for (std::size_t i = 0; i < image.size(); ++i) {
    const Eigen::Vector2d& a = image[i];
    const Eigen::Vector2d& b = image[(i + 1) % image.size()];
    twice_area += a.x() * b.y() - b.x() * a.y();
    *perimeter_px += (b - a).norm();
  }
  *area_px2 = std::abs(twice_area) / 2.0;
}

/// (yaw in degrees, particles per side): 2 per side is one quad of two triangles across the whole cloth,
/// where interpolating z instead of 1 / z would be centimetres off.
class FlatClothFacingTheCamera : public ::testing::TestWithParam<std::tuple<double, int>> {};

// The first test: every cloth pixel has the plane's depth within 1 mm, every pixel whose ray misses
// the cloth is NaN, and the cloth covers its projected area within one pixel row of its outline. Turned
// by 0, 30 and 60 degrees, so depth varies across each triangle (perspective-correct interpolation).
TEST_P(FlatClothFacingTheCamera, EveryPixelHasThePlanesDepthAndTheCountMatchesTheProjectedArea) {
  const double yaw_rad = std::get<0>(GetParam()) * kPi / 180.0;
  const PinholeCamera camera = vgaCamera();
  const Eigen::Isometry3d pose = cameraTwoMetresBefore();
  const ClothGrid grid = flatCloth(std::get<1>(GetParam()), yaw_rad);
  const DepthFrame frame = renderCloth(camera, pose, grid.rest_positions_m, grid.triangles);
  ASSERT_EQ(frame.depth_m.size(), 640u * 480u);

  // The cloth's plane in the optical frame: n . p = n . p0.
  const Eigen::Vector3d u_axis(std::cos(yaw_rad), std::sin(yaw_rad), 0.0);
  const Eigen::Vector3d v_axis(0.0, 0.0, -1.0);
  const Eigen::Vector3d centre_world(0.0, 0.0, 1.0);
  const Eigen::Isometry3d optical_from_world = pose.inverse();
  const Eigen::Vector3d centre = optical_from_world * centre_world;
  const Eigen::Vector3d normal = optical_from_world.linear() * u_axis.cross(v_axis);
  constexpr double kEdgeMargin_m = 1e-6;  // rays this close to the outline may go either way
  int cloth_pixels = 0;
  int checked_off = 0;
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const Eigen::Vector3d ray = pixelRay(camera, u, v);
      const double depth_m = normal.dot(centre) / normal.dot(ray);
      const Eigen::Vector3d hit_world = pose * (depth_m * ray);
      const double along_u = (hit_world - centre_world).dot(u_axis);
      const double along_v = (hit_world - centre_world).dot(v_axis);
      const double outside_m = std::max(std::abs(along_u), std::abs(along_v)) - 0.5;
      const float seen = frame.depth_m[pixelIndex(frame, u, v)];
      if (std::isfinite(seen)) {
        ++cloth_pixels;
        ASSERT_NEAR(seen, depth_m, kDepthTolerance_m) << "pixel (" << u << ", " << v << ")";
        ASSERT_LE(outside_m, kEdgeMargin_m) << "pixel (" << u << ", " << v << ") is off the cloth";
        EXPECT_EQ(frame.mask[pixelIndex(frame, u, v)], DepthFrame::kClothMask);
      } else {
        EXPECT_EQ(frame.mask[pixelIndex(frame, u, v)], 0);
        ASSERT_GE(outside_m, -kEdgeMargin_m) << "pixel (" << u << ", " << v << ") is on the cloth but NaN";
        ++checked_off;
      }
    }
  }
  double area_px2 = 0.0;
  double perimeter_px = 0.0;
  projectedPolygon(camera, pose,
                   {centre_world + 0.5 * (-u_axis - v_axis), centre_world + 0.5 * (u_axis - v_axis),
                    centre_world + 0.5 * (u_axis + v_axis), centre_world + 0.5 * (-u_axis + v_axis)},
                   &area_px2, &perimeter_px);
  EXPECT_GT(area_px2, 10000.0) << "the cloth should fill a good part of the image";
  EXPECT_NEAR(cloth_pixels, area_px2, perimeter_px);
  EXPECT_GT(checked_off, 0);
}

INSTANTIATE_TEST_SUITE_P(YawAndGrid, FlatClothFacingTheCamera,
                         ::testing::Combine(::testing::Values(0.0, 30.0, 60.0), ::testing::Values(2, 64)));

// A cloth folded in half, its lower half turned up 10 cm behind the upper one: only the near layer shows,
// whichever layer's triangles come first.
TEST(DepthRender, AFoldsHiddenLayerDoesNotAppear) {
  constexpr int kSide = 41;
  constexpr int kCrease = 20;
  constexpr double kGap_m = 0.1;
  const ClothGrid grid = flatCloth(kSide, 0.0);
  Eigen::Matrix3Xd folded = grid.rest_positions_m;
  for (int r = kCrease + 1; r < kSide; ++r) {
    for (int c = 0; c < kSide; ++c) {
      folded.col(grid.index(r, c)) = grid.rest_positions_m.col(grid.index(2 * kCrease - r, c));
      folded(1, grid.index(r, c)) = kGap_m;  // farther from the camera (at y = -2)
    }
  }
  std::vector<int> reversed;
  for (std::size_t t = grid.triangles.size(); t >= 3; t -= 3) {
    reversed.insert(reversed.end(), grid.triangles.begin() + (t - 3), grid.triangles.begin() + t);
  }
  const PinholeCamera camera = vgaCamera();
  const std::vector<const std::vector<int>*> orders{&grid.triangles, &reversed};
  for (const std::vector<int>* triangles : orders) {
    const DepthFrame frame = renderCloth(camera, cameraTwoMetresBefore(), folded, *triangles);
    int seen = 0;
    for (int v = 0; v < frame.height; ++v) {
      for (int u = 0; u < frame.width; ++u) {
        const float depth_m = frame.depth_m[pixelIndex(frame, u, v)];
        if (!std::isfinite(depth_m)) continue;
        ++seen;
        // The near layer is the plane y = 0: depth 2 m along every ray (the camera looks along +y).
        ASSERT_NEAR(depth_m, 2.0, kDepthTolerance_m) << "pixel (" << u << ", " << v << ") shows the hidden layer";
      }
    }
    EXPECT_GT(seen, 10000);
  }
}

// Both sides of the cloth are seen: the same cloth from behind gives the same depths, mirrored.
TEST(DepthRender, BothSidesOfTheClothAreSeen) {
  const ClothGrid grid = flatCloth(16, 0.0);
  const PinholeCamera camera = vgaCamera();
  const DepthFrame front = renderCloth(camera, cameraTwoMetresBefore(), grid.rest_positions_m, grid.triangles);
  const DepthFrame back = renderCloth(camera, opticalLookAt({0.0, 2.0, 1.0}, {0.0, 0.0, 1.0}, Eigen::Vector3d::UnitZ()),
                                      grid.rest_positions_m, grid.triangles);
  int front_pixels = 0;
  int back_pixels = 0;
  for (std::size_t i = 0; i < front.depth_m.size(); ++i) {
    front_pixels += std::isfinite(front.depth_m[i]) ? 1 : 0;
    back_pixels += std::isfinite(back.depth_m[i]) ? 1 : 0;
  }
  EXPECT_GT(front_pixels, 10000);
  EXPECT_EQ(front_pixels, back_pixels);
}

// Colliders by ray casting: a floor under a camera looking straight down is at the camera's height in
// every pixel; a sphere's nearest point on the axis at its distance minus its radius; a box's face at
// its distance. The cloth in front of them occludes them and only the cloth is masked.
TEST(DepthRender, CollidersHaveTheirAnalyticDepths) {
  const PinholeCamera camera = vgaCamera();
  ColliderSet floor;
  floor.planes.push_back({Eigen::Vector3d::UnitZ(), 0.0});
  const Eigen::Isometry3d down = opticalLookAt({0.3, 0.2, 2.0}, {0.3, 0.2, 0.0}, Eigen::Vector3d::UnitY());
  const Eigen::Matrix3Xd no_particles(3, 0);
  const std::vector<int> no_triangles;
  const DepthFrame floor_frame = renderCloth(camera, down, no_particles, no_triangles, &floor);
  for (std::size_t i = 0; i < floor_frame.depth_m.size(); ++i) {
    ASSERT_NEAR(floor_frame.depth_m[i], 2.0, 1e-6) << "pixel " << i;
    ASSERT_EQ(floor_frame.mask[i], 0);
  }

  // A camera with an odd size has a pixel on its axis: (cx, cy) = (160, 120).
  CameraOptions odd;
  odd.width = 321;
  odd.height = 241;
  odd.cx_px = 160.0;
  odd.cy_px = 120.0;
  const PinholeCamera axis_camera = PinholeCamera::from(odd);
  const Eigen::Isometry3d level = cameraTwoMetresBefore();
  ColliderSet ball;
  ball.spheres.push_back({});
  ball.spheres[0].center_m = Eigen::Vector3d(0.0, 1.0, 1.0);  // 3 m in front
  ball.spheres[0].radius_m = 0.5;
  const DepthFrame ball_frame = renderCloth(axis_camera, level, no_particles, no_triangles, &ball);
  EXPECT_NEAR(ball_frame.depth_m[pixelIndex(ball_frame, 160, 120)], 2.5, 1e-6);
  EXPECT_TRUE(std::isnan(ball_frame.depth_m[pixelIndex(ball_frame, 0, 0)])) << "the corner ray misses the ball";

  ColliderSet table;
  table.boxes.push_back({Eigen::Vector3d(-0.2, -0.5, 0.8), Eigen::Vector3d(0.2, 0.5, 1.2)});  // face at y = -0.5
  const DepthFrame table_frame = renderCloth(axis_camera, level, no_particles, no_triangles, &table);
  EXPECT_NEAR(table_frame.depth_m[pixelIndex(table_frame, 160, 120)], 1.5, 1e-6);

  // The cloth (at 2 m) in front of the ball (2.5 m): the cloth wins and is masked.
  const ClothGrid grid = flatCloth(8, 0.0);
  const DepthFrame both = renderCloth(axis_camera, level, grid.rest_positions_m, grid.triangles, &ball);
  EXPECT_NEAR(both.depth_m[pixelIndex(both, 160, 120)], 2.0, kDepthTolerance_m);
  EXPECT_EQ(both.mask[pixelIndex(both, 160, 120)], DepthFrame::kClothMask);
  // The box (1.5 m) in front of the cloth: the box wins, unmasked.
  const DepthFrame hidden = renderCloth(axis_camera, level, grid.rest_positions_m, grid.triangles, &table);
  EXPECT_NEAR(hidden.depth_m[pixelIndex(hidden, 160, 120)], 1.5, 1e-6);
  EXPECT_EQ(hidden.mask[pixelIndex(hidden, 160, 120)], 0);
}

// A cloth resting on a collider lies up to the contact band inside it: with the scene's inset (twice
// the band) the cloth is seen, not the collider through it, and the collider's face is drawn that far in.
TEST(DepthRender, AClothInTheContactBandIsSeenOverItsCollider) {
  CameraOptions odd;
  odd.width = 321;
  odd.height = 241;
  odd.cx_px = 160.0;
  odd.cy_px = 120.0;
  const PinholeCamera camera = PinholeCamera::from(odd);
  const Eigen::Isometry3d level = opticalLookAt({0.0, -2.0, 1.0}, {0.0, 0.0, 1.0}, Eigen::Vector3d::UnitZ());
  ContactOptions contact;  // a 2 mm band
  ColliderSet wall;
  wall.boxes.push_back({Eigen::Vector3d(-1.0, 0.0, 0.0), Eigen::Vector3d(1.0, 1.0, 2.0)});  // its face at y = 0
  ClothGrid grid = flatCloth(8, 0.0);
  Eigen::Matrix3Xd resting = grid.rest_positions_m;
  resting.row(1).setConstant(contact.depth_m * 0.9);  // just inside the face, within the band
  RenderScene scene;
  scene.positions_m = &resting;
  scene.triangles = &grid.triangles;
  scene.colliders = &wall;
  scene.collider_inset_m = colliderInset_m(contact);
  EXPECT_EQ(scene.collider_inset_m, 2.0 * contact.depth_m);
  DepthRenderer renderer;
  DepthFrame frame;
  renderer.render(camera, level, scene, false, &frame);
  const std::size_t centre = pixelIndex(frame, 160, 120);
  EXPECT_EQ(frame.mask[centre], DepthFrame::kClothMask);
  EXPECT_NEAR(frame.depth_m[centre], 2.0 + 0.9 * contact.depth_m, 1e-5);
  const std::size_t off_cloth = pixelIndex(frame, 10, 120);  // the wall beside the cloth
  EXPECT_EQ(frame.mask[off_cloth], 0);
  EXPECT_NEAR(frame.depth_m[off_cloth], 2.0 + scene.collider_inset_m, 1e-5);
  scene.collider_inset_m = 0.0;  // without it the collider hides the cloth: what the inset is for
  renderer.render(camera, level, scene, false, &frame);
  EXPECT_EQ(frame.mask[centre], 0);
}

// Outside [min_range, max_range] nothing is seen; a cloth crossing the near plane is cut there, not lost.
TEST(DepthRender, RangesClipTheImage) {
  const ClothGrid grid = flatCloth(16, 0.0);
  CameraOptions options;
  options.max_range_m = 1.9;
  const DepthFrame far = renderCloth(PinholeCamera::from(options), cameraTwoMetresBefore(), grid.rest_positions_m,
                                     grid.triangles);
  options = CameraOptions();
  options.min_range_m = 2.1;
  const DepthFrame near = renderCloth(PinholeCamera::from(options), cameraTwoMetresBefore(), grid.rest_positions_m,
                                      grid.triangles);
  for (std::size_t i = 0; i < far.depth_m.size(); ++i) {
    ASSERT_TRUE(std::isnan(far.depth_m[i]));
    ASSERT_TRUE(std::isnan(near.depth_m[i]));
  }
  // Turned by 80 degrees and seen from 0.6 m, the cloth's near half lies inside the 0.3 m blind zone.
  const ClothGrid turned = flatCloth(32, 80.0 * kPi / 180.0);
  const DepthFrame cut = renderCloth(vgaCamera(), opticalLookAt({0.0, -0.6, 1.0}, {0.0, 0.0, 1.0}, Eigen::Vector3d::UnitZ()),
                                     turned.rest_positions_m, turned.triangles);
  int seen = 0;
  for (float depth_m : cut.depth_m) {
    if (!std::isfinite(depth_m)) continue;
    ++seen;
    ASSERT_GE(depth_m, 0.3 - 1e-6);
  }
  EXPECT_GT(seen, 1000);
}

// The colour image: a red cloth facing the camera is red, full bright (the light is at the camera).
TEST(DepthRender, ColourImageShowsTheClothsColours) {
  const ClothGrid grid = flatCloth(8, 0.0);
  const Eigen::Matrix3Xf red = Eigen::Vector3f(1.0f, 0.0f, 0.0f).replicate(1, grid.particleCount());
  const DepthFrame frame =
      renderCloth(vgaCamera(), cameraTwoMetresBefore(), grid.rest_positions_m, grid.triangles, nullptr, true, &red);
  ASSERT_EQ(frame.rgb.size(), 3u * 640u * 480u);
  const std::size_t centre = pixelIndex(frame, 320, 240);
  EXPECT_EQ(frame.rgb[3 * centre], 255);
  EXPECT_EQ(frame.rgb[3 * centre + 1], 0);
  EXPECT_EQ(frame.rgb[3 * centre + 2], 0);
  EXPECT_EQ(frame.rgb[0], 0) << "nothing seen is black";
}

// Same inputs, same bits: an image is a pure function of the scene and the pose.
TEST(DepthRender, RenderingIsDeterministic) {
  const ClothGrid grid = flatCloth(32, 0.4);
  ColliderSet colliders;
  colliders.planes.push_back({Eigen::Vector3d::UnitZ(), -0.4});
  colliders.spheres.push_back({});
  const DepthFrame a = renderCloth(vgaCamera(), cameraTwoMetresBefore(), grid.rest_positions_m, grid.triangles, &colliders, true);
  const DepthFrame b = renderCloth(vgaCamera(), cameraTwoMetresBefore(), grid.rest_positions_m, grid.triangles, &colliders, true);
  ASSERT_EQ(a.depth_m.size(), b.depth_m.size());
  EXPECT_EQ(std::memcmp(a.depth_m.data(), b.depth_m.data(), a.depth_m.size() * sizeof(float)), 0);
  EXPECT_EQ(a.mask, b.mask);
  EXPECT_EQ(a.rgb, b.rgb);
}

// noise: kinect: Nguyen, Izadi and Lovell's sigma at 2 m (6.06 mm), zero mean, reproducible for a seed and
// frame, different for another frame.
TEST(DepthRender, KinectNoiseHasThePublishedSpreadAndReproduces) {
  EXPECT_NEAR(kinectDepthSigma_m(0.4), 0.0012, 1e-12);
  EXPECT_NEAR(kinectDepthSigma_m(2.0), 0.0012 + 0.0019 * 1.6 * 1.6, 1e-12);
  const ClothGrid grid = flatCloth(16, 0.0);
  const PinholeCamera camera = vgaCamera();
  const DepthFrame clean = renderCloth(camera, cameraTwoMetresBefore(), grid.rest_positions_m, grid.triangles);
  DepthFrame noisy = clean;
  addKinectNoise(7, 100, camera, &noisy);
  DepthFrame again = clean;
  addKinectNoise(7, 100, camera, &again);
  DepthFrame next = clean;
  addKinectNoise(7, 101, camera, &next);
  double sum = 0.0;
  double sum_squares = 0.0;
  int count = 0;
  int same_as_next = 0;
  for (std::size_t i = 0; i < clean.depth_m.size(); ++i) {
    if (!std::isfinite(clean.depth_m[i])) {
      ASSERT_TRUE(std::isnan(noisy.depth_m[i]));
      continue;
    }
    const double error = static_cast<double>(noisy.depth_m[i]) - clean.depth_m[i];
    sum += error;
    sum_squares += error * error;
    ++count;
    ASSERT_EQ(noisy.depth_m[i], again.depth_m[i]);
    same_as_next += noisy.depth_m[i] == next.depth_m[i] ? 1 : 0;
  }
  ASSERT_GT(count, 50000);
  const double sigma = kinectDepthSigma_m(2.0);
  const double mean = sum / count;
  const double spread = std::sqrt(sum_squares / count - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4.0 * sigma / std::sqrt(count));
  EXPECT_NEAR(spread, sigma, 0.02 * sigma);
  EXPECT_LT(same_as_next, count / 100) << "another frame must draw other noise";
}

}  // namespace
}  // namespace cloth_sim::core
