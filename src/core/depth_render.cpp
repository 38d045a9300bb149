#include "cloth_sim/core/depth_render.h"

#include "cloth_sim/core/constants.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace cloth_sim::core {

namespace {

constexpr float kNoSurface = std::numeric_limits<float>::infinity();
/// Shading of the colour image: a light at the camera, ambient + diffuse |cos| of the angle between the
/// surface normal and the ray (both sides of the cloth lit alike).
constexpr float kAmbient = 0.35f;
constexpr float kDiffuse = 0.65f;
/// Colliders' base colour in the colour image (RGB in [0, 1]): a neutral grey, as rviz draws them.
constexpr float kColliderGrey = 0.6f;
constexpr float kMaxByte = 255.0f;
/// A projected triangle with less image area than this (pixels^2) is seen edge-on: it covers no pixel
/// centre reliably and its barycentric weights would divide by almost zero.
constexpr double kMinProjectedArea_px2 = 1e-12;

/// A vertex in the optical frame with its colour, as near-plane clipping makes new ones.
struct ClipVertex {
  Eigen::Vector3d position_m;
  Eigen::Vector3f color;
};

/// Clips a triangle to z >= near_m (Sutherland-Hodgman against one plane): 0, 3 or 4 vertices.
int clipToNearPlane(const std::array<ClipVertex, 3>& triangle, double near_m, std::array<ClipVertex, 4>* out) {
  int count = 0;
  for (int i = 0; i < 3; ++i) {
    const ClipVertex& current = triangle[i];
    const ClipVertex& next = triangle[(i + 1) % 3];
    const bool current_in = current.position_m.z() >= near_m;
    const bool next_in = next.position_m.z() >= near_m;
    if (current_in) (*out)[count++] = current;
    if (current_in != next_in) {
      const double s = (near_m - current.position_m.z()) / (next.position_m.z() - current.position_m.z());
      ClipVertex cut;
      cut.position_m = current.position_m + s * (next.position_m - current.position_m);
      cut.position_m.z() = near_m;  // exactly on the plane, whatever the rounding of the line above
      cut.color = current.color + static_cast<float>(s) * (next.color - current.color);
      (*out)[count++] = cut;
    }
  }
  return count;
}

float shade(const Eigen::Vector3d& normal, const Eigen::Vector3d& ray) {
  const double norms = normal.norm() * ray.norm();
  const double cosine = norms > 0.0 ? std::abs(normal.dot(ray)) / norms : 1.0;
  return kAmbient + kDiffuse * static_cast<float>(cosine);
}

std::uint8_t toByte(float value) {
  return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0f, 1.0f) * kMaxByte));
}

void writeColor(DepthFrame* frame, std::size_t pixel, const Eigen::Vector3f& color) {
  for (int k = 0; k < 3; ++k) frame->rgb[3 * pixel + k] = toByte(color[k]);
}

/// splitmix64 (Steele, Lea and Flood 2014): a counter-based generator, so each pixel's draw is a pure
/// function of its key.
std::uint64_t splitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// A uniform number in (0, 1] from the top 53 bits.
double unitInterval(std::uint64_t bits) {
  constexpr double kTwoToMinus53 = 1.0 / 9007199254740992.0;
  return (static_cast<double>(bits >> 11) + 1.0) * kTwoToMinus53;
}

}  // namespace

PinholeCamera PinholeCamera::from(const CameraOptions& options) {
  PinholeCamera camera;
  camera.width = options.width;
  camera.height = options.height;
  camera.fx_px = options.fx_px;
  camera.fy_px = options.fy_px;
  camera.cx_px = options.cx_px;
  camera.cy_px = options.cy_px;
  camera.min_range_m = options.min_range_m;
  camera.max_range_m = options.max_range_m;
  return camera;
}

void DepthRenderer::render(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical,
                           const RenderScene& scene, bool with_color, DepthFrame* frame) {
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  frame->width = camera.width;
  frame->height = camera.height;
  frame->depth_m.assign(pixels, kNoSurface);
  frame->mask.assign(pixels, 0);
  if (with_color) {
    frame->rgb.assign(3 * pixels, 0);
  } else {
    frame->rgb.clear();
  }
  if (scene.colliders && !scene.colliders->empty()) {
    castColliders(camera, world_from_optical, *scene.colliders, scene.time_s, scene.collider_inset_m, with_color,
                  frame);
  }
  if (scene.positions_m && scene.triangles) rasterizeCloth(camera, world_from_optical, scene, with_color, frame);
  const float max_range_m = static_cast<float>(camera.max_range_m);
  for (std::size_t i = 0; i < pixels; ++i) {
    if (frame->depth_m[i] > max_range_m) {  // also kNoSurface
      frame->depth_m[i] = std::numeric_limits<float>::quiet_NaN();
      frame->mask[i] = 0;
      if (with_color) writeColor(frame, i, Eigen::Vector3f::Zero());
    }
  }
}

namespace {

/// Pixels [u_first, u_last] x [v_first, v_last] (inclusive; empty when first > last) that one collider may
/// cover.
struct PixelBox {
  int u_first, u_last, v_first, v_last;
};

PixelBox wholeImage(const PinholeCamera& camera) { return {0, camera.width - 1, 0, camera.height - 1}; }

/// The pixels the convex hull of `corners` (optical frame) can cover: the box of their projections; the
/// whole image when one lies nearer than min_range (its projection is then unbounded).
PixelBox projectedBox(const PinholeCamera& camera, const std::array<Eigen::Vector3d, 8>& corners) {
  double u_low = std::numeric_limits<double>::infinity();
  double v_low = u_low;
  double u_high = -u_low;
  double v_high = -u_low;
  for (const Eigen::Vector3d& p : corners) {
    if (!(p.z() >= camera.min_range_m)) return wholeImage(camera);
    const double u = camera.fx_px * p.x() / p.z() + camera.cx_px;
    const double v = camera.fy_px * p.y() / p.z() + camera.cy_px;
    u_low = std::min(u_low, u);
    u_high = std::max(u_high, u);
    v_low = std::min(v_low, v);
    v_high = std::max(v_high, v);
  }
  const auto first = [](double value, int size) {
    return static_cast<int>(std::ceil(std::clamp(value, 0.0, static_cast<double>(size))));
  };
  const auto last = [](double value, int size) {
    return static_cast<int>(std::floor(std::clamp(value, -1.0, static_cast<double>(size - 1))));
  };
  return {first(u_low, camera.width), last(u_high, camera.width), first(v_low, camera.height),
          last(v_high, camera.height)};
}

}  // namespace

void DepthRenderer::castColliders(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical,
                                  const ColliderSet& colliders, double time_s, double inset_m, bool with_color,
                                  DepthFrame* frame) {
  // Every ray is t (the camera centre) + s R d with d = ((u - cx) / fx, (v - cy) / fy, 1) in the optical
  // frame: d's z is 1, so the parameter s of a hit is its depth z. Each collider is cast over the pixels
  // its projection can cover, and a hit is kept where it is nearer than what the pixel holds (colliders
  // in the order planes, spheres, boxes; a tie keeps the first).
  const Eigen::Matrix3d rotation = world_from_optical.linear();
  const Eigen::Matrix3d optical_from_world = rotation.transpose();
  const Eigen::Vector3d origin_m = world_from_optical.translation();
  const auto rayOf = [&camera](int u, int v) {
    return Eigen::Vector3d((u - camera.cx_px) / camera.fx_px, (v - camera.cy_px) / camera.fy_px, 1.0);
  };
  const auto keep = [&](int u, int v, double depth_m, const Eigen::Vector3d& ray, const Eigen::Vector3d& normal) {
    if (!(depth_m >= camera.min_range_m)) return;
    const std::size_t pixel = static_cast<std::size_t>(v) * camera.width + u;
    const float depth = static_cast<float>(depth_m);
    if (!(depth < frame->depth_m[pixel])) return;
    frame->depth_m[pixel] = depth;
    if (with_color) writeColor(frame, pixel, Eigen::Vector3f::Constant(kColliderGrey * shade(normal, ray)));
  };

  for (const PlaneCollider& plane : colliders.planes) {
    const Eigen::Vector3d normal = optical_from_world * plane.normal;
    // Signed, from the plane moved inset_m into the collider (n . x + d = -inset).
    const double camera_height_m = plane.normal.dot(origin_m) + plane.offset_m + inset_m;
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const Eigen::Vector3d ray = rayOf(u, v);
        const double rate = normal.dot(ray);
        if (rate != 0.0) keep(u, v, -camera_height_m / rate, ray, normal);
      }
    }
  }
  for (const SphereCollider& sphere : colliders.spheres) {
    const Eigen::Vector3d center = optical_from_world * (sphere.centerAt(time_s) - origin_m);
    const double radius = sphere.radius_m - inset_m;
    if (!(radius > 0.0)) continue;
    const double camera_term_m2 = center.squaredNorm() - radius * radius;  // negative with the camera inside
    std::array<Eigen::Vector3d, 8> corners;
    for (int k = 0; k < 8; ++k) {
      corners[k] = center + radius * Eigen::Vector3d(k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0);
    }
    const PixelBox box = projectedBox(camera, corners);
    for (int v = box.v_first; v <= box.v_last; ++v) {
      for (int u = box.u_first; u <= box.u_last; ++u) {
        // |s d - c|^2 = r^2: a s^2 - 2 b s + k = 0; the near root, or the far one from inside.
        const Eigen::Vector3d ray = rayOf(u, v);
        const double a = ray.squaredNorm();
        const double b = ray.dot(center);
        const double discriminant = b * b - a * camera_term_m2;
        if (discriminant < 0.0) continue;
        const double root = std::sqrt(discriminant);
        const double depth_m = camera_term_m2 > 0.0 ? (b - root) / a : (b + root) / a;
        keep(u, v, depth_m, ray, depth_m * ray - center);
      }
    }
  }
  for (const BoxCollider& drawn : colliders.boxes) {
    const BoxCollider box{drawn.min_m.array() + inset_m, drawn.max_m.array() - inset_m};
    if (!((box.max_m - box.min_m).minCoeff() > 0.0)) continue;
    std::array<Eigen::Vector3d, 8> corners;
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector3d corner(k & 1 ? box.max_m.x() : box.min_m.x(), k & 2 ? box.max_m.y() : box.min_m.y(),
                                   k & 4 ? box.max_m.z() : box.min_m.z());
      corners[k] = optical_from_world * (corner - origin_m);
    }
    const PixelBox pixels = projectedBox(camera, corners);
    for (int v = pixels.v_first; v <= pixels.v_last; ++v) {
      for (int u = pixels.u_first; u <= pixels.u_last; ++u) {
        // Slabs (Kay and Kajiya): the ray is inside the box between its last entry and first exit.
        const Eigen::Vector3d ray = rayOf(u, v);
        const Eigen::Vector3d direction = rotation * ray;  // world frame
        double enter = -std::numeric_limits<double>::infinity();
        double leave = std::numeric_limits<double>::infinity();
        int enter_axis = 0;
        int leave_axis = 0;
        bool missed = false;
        for (int axis = 0; axis < 3 && !missed; ++axis) {
          if (direction[axis] == 0.0) {
            missed = origin_m[axis] < box.min_m[axis] || origin_m[axis] > box.max_m[axis];
            continue;
          }
          const double inverse = 1.0 / direction[axis];
          const double s1 = (box.min_m[axis] - origin_m[axis]) * inverse;
          const double s2 = (box.max_m[axis] - origin_m[axis]) * inverse;
          if (std::min(s1, s2) > enter) {
            enter = std::min(s1, s2);
            enter_axis = axis;
          }
          if (std::max(s1, s2) < leave) {
            leave = std::max(s1, s2);
            leave_axis = axis;
          }
        }
        if (missed || enter > leave || leave <= 0.0) continue;
        const bool from_outside = enter > 0.0;
        keep(u, v, from_outside ? enter : leave, ray,
             optical_from_world * Eigen::Vector3d::Unit(from_outside ? enter_axis : leave_axis));
      }
    }
  }
}

namespace {

/// One triangle in the image: pixel coordinates, 1 / z and colour per corner.
struct ScreenTriangle {
  double u[3];
  double v[3];
  double inverse_z[3];
  const Eigen::Vector3f* color[3];
};

/// Fills the pixel centres inside the triangle (either winding: both sides are seen) where it is nearer
/// than what the pixel holds: depth from the barycentric interpolation of 1 / z (linear in the image,
/// so exact for the triangle's plane), colour perspective-correct, times `brightness`.
void fillTriangle(const PinholeCamera& camera, const ScreenTriangle& t, bool with_color, float brightness,
                  DepthFrame* frame) {
  const double area = (t.u[1] - t.u[0]) * (t.v[2] - t.v[0]) - (t.v[1] - t.v[0]) * (t.u[2] - t.u[0]);
  if (!(std::abs(area) > kMinProjectedArea_px2)) return;  // also NaN
  // Pixel centres in the bounding box, clamped to the image before any conversion to int.
  const double last_u = camera.width - 1;
  const double last_v = camera.height - 1;
  const double u_low = std::ceil(std::clamp(std::min({t.u[0], t.u[1], t.u[2]}), 0.0, last_u + 1.0));
  const double u_high = std::floor(std::clamp(std::max({t.u[0], t.u[1], t.u[2]}), -1.0, last_u));
  const double v_low = std::ceil(std::clamp(std::min({t.v[0], t.v[1], t.v[2]}), 0.0, last_v + 1.0));
  const double v_high = std::floor(std::clamp(std::max({t.v[0], t.v[1], t.v[2]}), -1.0, last_v));
  const double inverse_area = 1.0 / area;
  for (int v = static_cast<int>(v_low); v <= static_cast<int>(v_high); ++v) {
    for (int u = static_cast<int>(u_low); u <= static_cast<int>(u_high); ++u) {
      // Barycentric weights from the edge functions, signed by the area.
      const double w0 = ((t.u[2] - t.u[1]) * (v - t.v[1]) - (t.v[2] - t.v[1]) * (u - t.u[1])) * inverse_area;
      const double w1 = ((t.u[0] - t.u[2]) * (v - t.v[2]) - (t.v[0] - t.v[2]) * (u - t.u[2])) * inverse_area;
      const double w2 = ((t.u[1] - t.u[0]) * (v - t.v[0]) - (t.v[1] - t.v[0]) * (u - t.u[0])) * inverse_area;
      if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0) continue;
      const double inverse_depth = w0 * t.inverse_z[0] + w1 * t.inverse_z[1] + w2 * t.inverse_z[2];
      const float depth_m = static_cast<float>(1.0 / inverse_depth);
      const std::size_t pixel = static_cast<std::size_t>(v) * camera.width + u;
      if (!(depth_m < frame->depth_m[pixel])) continue;
      frame->depth_m[pixel] = depth_m;
      frame->mask[pixel] = DepthFrame::kClothMask;
      if (with_color) {
        // Colour / z interpolates linearly in the image, as 1 / z does.
        const Eigen::Vector3f color = (static_cast<float>(w0 * t.inverse_z[0]) * *t.color[0] +
                                       static_cast<float>(w1 * t.inverse_z[1]) * *t.color[1] +
                                       static_cast<float>(w2 * t.inverse_z[2]) * *t.color[2]) /
                                      static_cast<float>(inverse_depth);
        writeColor(frame, pixel, brightness * color);
      }
    }
  }
}

}  // namespace

void DepthRenderer::rasterizeCloth(const PinholeCamera& camera, const Eigen::Isometry3d& world_from_optical,
                                   const RenderScene& scene, bool with_color, DepthFrame* frame) {
  const Eigen::Matrix3d optical_from_world = world_from_optical.linear().transpose();
  optical_positions_m_ = optical_from_world * (scene.positions_m->colwise() - world_from_optical.translation());
  const Eigen::Index count = optical_positions_m_.cols();
  // Each vertex projected once (a grid vertex is shared by up to six triangles): u, v, 1 / z; only
  // meaningful for vertices at or beyond the near plane (triangles with one nearer are clipped first).
  projected_.resize(3, count);
  for (Eigen::Index i = 0; i < count; ++i) {
    const Eigen::Vector3d p = optical_positions_m_.col(i);
    const double inverse_z = 1.0 / p.z();
    projected_.col(i) << camera.fx_px * p.x() * inverse_z + camera.cx_px, camera.fy_px * p.y() * inverse_z + camera.cy_px,
        inverse_z;
  }
  const std::vector<int>& triangles = *scene.triangles;
  const bool has_colors = scene.colors && scene.colors->cols() == count;
  const Eigen::Vector3f white = Eigen::Vector3f::Ones();
  colors_.resize(static_cast<std::size_t>(count));
  for (Eigen::Index i = 0; i < count; ++i) colors_[static_cast<std::size_t>(i)] = has_colors ? Eigen::Vector3f(scene.colors->col(i)) : white;

  std::array<ClipVertex, 3> corners;
  std::array<ClipVertex, 4> clipped;
  ScreenTriangle screen;
  for (std::size_t t = 0; t + 2 < triangles.size(); t += 3) {
    const int a = triangles[t];
    const int b = triangles[t + 1];
    const int c = triangles[t + 2];
    const int in_front = (optical_positions_m_(2, a) >= camera.min_range_m ? 1 : 0) +
                         (optical_positions_m_(2, b) >= camera.min_range_m ? 1 : 0) +
                         (optical_positions_m_(2, c) >= camera.min_range_m ? 1 : 0);
    if (in_front == 0) continue;
    float brightness = 1.0f;
    if (with_color) {
      const Eigen::Vector3d pa = optical_positions_m_.col(a);
      const Eigen::Vector3d pb = optical_positions_m_.col(b);
      const Eigen::Vector3d pc = optical_positions_m_.col(c);
      brightness = shade((pb - pa).cross(pc - pa), pa + pb + pc);
    }
    if (in_front == 3) {  // the common case: no clipping, the vertices' projections as they are
      const int corner[3] = {a, b, c};
      for (int k = 0; k < 3; ++k) {
        screen.u[k] = projected_(0, corner[k]);
        screen.v[k] = projected_(1, corner[k]);
        screen.inverse_z[k] = projected_(2, corner[k]);
        screen.color[k] = &colors_[static_cast<std::size_t>(corner[k])];
      }
      fillTriangle(camera, screen, with_color, brightness, frame);
      continue;
    }
    const int corner[3] = {a, b, c};
    for (int k = 0; k < 3; ++k) {
      corners[k].position_m = optical_positions_m_.col(corner[k]);
      corners[k].color = colors_[static_cast<std::size_t>(corner[k])];
    }
    const int clipped_count = clipToNearPlane(corners, camera.min_range_m, &clipped);
    for (int fan = 1; fan + 1 < clipped_count; ++fan) {
      const ClipVertex* vertex[3] = {&clipped[0], &clipped[fan], &clipped[fan + 1]};
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d& p = vertex[k]->position_m;
        screen.inverse_z[k] = 1.0 / p.z();
        screen.u[k] = camera.fx_px * p.x() * screen.inverse_z[k] + camera.cx_px;
        screen.v[k] = camera.fy_px * p.y() * screen.inverse_z[k] + camera.cy_px;
        screen.color[k] = &vertex[k]->color;
      }
      fillTriangle(camera, screen, with_color, brightness, frame);
    }
  }
}

double colliderInset_m(const ContactOptions& contact) {
  constexpr double kMinInset_m = 0.001;
  return std::max(2.0 * contact.depth_m, kMinInset_m);
}

Eigen::Isometry3d opticalLookAt(const Eigen::Vector3d& eye_m, const Eigen::Vector3d& target_m,
                                const Eigen::Vector3d& up_axis) {
  const Eigen::Vector3d forward = (target_m - eye_m).normalized();
  const Eigen::Vector3d right = forward.cross(up_axis).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Isometry3d world_from_optical = Eigen::Isometry3d::Identity();
  world_from_optical.linear().col(0) = right;
  world_from_optical.linear().col(1) = down;
  world_from_optical.linear().col(2) = forward;
  world_from_optical.translation() = eye_m;
  return world_from_optical;
}

double kinectDepthSigma_m(double depth_m) {
  // Nguyen, Izadi and Lovell (2012), eq. for the axial noise: 0.0012 + 0.0019 (z - 0.4)^2 m.
  constexpr double kBase_m = 0.0012;
  constexpr double kQuadratic_per_m = 0.0019;
  constexpr double kOffset_m = 0.4;
  const double beyond_m = depth_m - kOffset_m;
  return kBase_m + kQuadratic_per_m * beyond_m * beyond_m;
}

void addKinectNoise(std::uint32_t seed, std::uint64_t frame_number, const PinholeCamera& camera, DepthFrame* frame) {
  const std::uint64_t image_key = splitMix64(splitMix64(seed) ^ frame_number);
  for (std::size_t pixel = 0; pixel < frame->depth_m.size(); ++pixel) {
    const float depth_m = frame->depth_m[pixel];
    if (!std::isfinite(depth_m)) continue;
    // Box-Muller on two independent uniforms of this pixel's key.
    const std::uint64_t first = splitMix64(image_key ^ (2 * pixel));
    const std::uint64_t second = splitMix64(image_key ^ (2 * pixel + 1));
    const double gaussian = std::sqrt(-2.0 * std::log(unitInterval(first))) * std::cos(kTwoPi * unitInterval(second));
    const double noisy_m = depth_m + kinectDepthSigma_m(depth_m) * gaussian;
    frame->depth_m[pixel] = noisy_m >= camera.min_range_m && noisy_m <= camera.max_range_m
                                ? static_cast<float>(noisy_m)
                                : std::numeric_limits<float>::quiet_NaN();
  }
}

}  // namespace cloth_sim::core
