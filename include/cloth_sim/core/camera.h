// Simulated depth cameras: what a scene's `cameras` entries hold. The renderer is depth_render.h; the ROS
// side (tf poses, topics) is ros/depth_cameras.h.
#pragma once

#include <cstdint>
#include <string>

namespace cloth_sim::core {

/// Depth noise models. kKinect: structured-light axial noise growing with the square of the distance
/// (Nguyen, Izadi and Lovell 2012, kinectDepthSigma_m in depth_render.h).
enum class DepthNoise { kNone, kKinect };

/// "none" or "kinect": the names scene files and parameters use.
const char* depthNoiseName(DepthNoise noise);
bool parseDepthNoiseName(const std::string& name, DepthNoise* noise);

/// One pinhole depth camera. The image lies in an optical frame as REP 103 gives it (z forward along the
/// optical axis, x right, y down); pixel (u, v) (column, row; integers at pixel centres, as CameraInfo
/// and depth_image_proc count them) looks along ((u - cx) / fx, (v - cy) / fy, 1).
struct CameraOptions {
  std::string name;   ///< its topics are ~<name>/...: a ROS name (a letter, then letters, digits, '_')
  std::string frame;  ///< its tf optical frame; posed from tf at each image's time
  int width = 640;    ///< pixels; the defaults are a Kinect / Xtion's VGA depth stream
  int height = 480;
  double fx_px = 525.0;  ///< focal lengths, pixels
  double fy_px = 525.0;
  /// Principal point, pixels; a scene entry that gives no cx / cy gets the image centre
  /// ((width - 1) / 2, (height - 1) / 2).
  double cx_px = 319.5;
  double cy_px = 239.5;
  double rate_hz = 30.0;      ///< images per second at most (one per simulated frame at most)
  double min_range_m = 0.3;   ///< nearer than this along z: clipped (NaN), as a real sensor's blind zone
  double max_range_m = 10.0;  ///< farther than this along z: NaN
  DepthNoise noise = DepthNoise::kNone;
  /// Seeds the depth noise; with the simulated frame number it fixes every image's noise, so a run
  /// reproduces.
  std::uint32_t seed = 0;
};

/// Ranges that validateSceneOptions enforces on cameras (and the README quotes).
struct CameraLimits {
  /// At most 4096 x 4096 (16.8 MPixel) per image: a z-buffer of floats is then 64 MiB.
  static constexpr int kMaxImageSide = 4096;
  static constexpr double kMaxFocalLength_px = 1e6;
  static constexpr double kMaxRateHz = 1000.0;  ///< the frame rate's limit (OptionLimits::kMaxFrameRateHz)
  static constexpr double kMaxRange_m = 1000.0;
  static constexpr int kMaxCameras = 16;
};

}  // namespace cloth_sim::core
