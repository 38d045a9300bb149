#include "cloth_sim/ros/sensor_conversions.h"

#include <sensor_msgs/image_encodings.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace cloth_sim {

namespace {

constexpr std::uint32_t kFloatBytes = sizeof(float);
/// x, y, z and one float32 more (rgb, or padding as PCL and depth_image_proc lay xyz clouds out).
constexpr std::uint32_t kPointStep = 4 * kFloatBytes;
constexpr std::uint8_t kLittleEndian = 0;
constexpr float kMaxByte = 255.0f;

sensor_msgs::PointField floatField(const std::string& name, std::uint32_t offset) {
  sensor_msgs::PointField field;
  field.name = name;
  field.offset = offset;
  field.datatype = sensor_msgs::PointField::FLOAT32;
  field.count = 1;
  return field;
}

/// An empty cloud of width x height points with the fields x, y, z and optionally rgb.
sensor_msgs::PointCloud2 emptyCloud(std::uint32_t width, std::uint32_t height, bool with_rgb,
                                    const std::string& frame_id, const ros::Time& stamp) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header.frame_id = frame_id;
  cloud.header.stamp = stamp;
  cloud.width = width;
  cloud.height = height;
  cloud.fields = {floatField("x", 0), floatField("y", kFloatBytes), floatField("z", 2 * kFloatBytes)};
  if (with_rgb) cloud.fields.push_back(floatField("rgb", 3 * kFloatBytes));
  cloud.is_bigendian = kLittleEndian;
  cloud.point_step = kPointStep;
  cloud.row_step = kPointStep * width;
  cloud.data.assign(static_cast<std::size_t>(cloud.row_step) * height, 0);
  return cloud;
}

void writeFloats(std::uint8_t* point, const float* values, int count) {
  std::memcpy(point, values, sizeof(float) * static_cast<std::size_t>(count));
}

std::uint32_t packRgb(const Eigen::Vector3f& color) {
  std::uint32_t packed = 0;
  for (int k = 0; k < 3; ++k) {
    const float channel = std::min(std::max(color[k], 0.0f), 1.0f);
    packed = (packed << 8) | static_cast<std::uint32_t>(std::lround(channel * kMaxByte));
  }
  return packed;
}

sensor_msgs::Image emptyImage(const core::DepthFrame& frame, const std::string& encoding, std::uint32_t bytes_per_pixel,
                              const std::string& optical_frame, const ros::Time& stamp) {
  sensor_msgs::Image image;
  image.header.frame_id = optical_frame;
  image.header.stamp = stamp;
  image.width = static_cast<std::uint32_t>(frame.width);
  image.height = static_cast<std::uint32_t>(frame.height);
  image.encoding = encoding;
  image.is_bigendian = kLittleEndian;
  image.step = image.width * bytes_per_pixel;
  return image;
}

}  // namespace

sensor_msgs::PointCloud2 toParticleCloud(const core::Simulation& simulation, const std::string& frame_id,
                                         const ros::Time& stamp) {
  const core::ClothGrid& grid = simulation.grid();
  sensor_msgs::PointCloud2 cloud = emptyCloud(grid.cols, grid.rows, true, frame_id, stamp);
  // Organised (rows x cols): a particle outside the cloth's outline is an invalid point, NaN, as REP 118
  // and the PCL convention have it, so the cloud is then not dense.
  cloud.is_dense = !grid.hasOutline();
  constexpr float kInvalid = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Matrix3Xd& positions_m = simulation.state().positions_m;
  const Eigen::Matrix3Xf& colors = simulation.vertexColors();
  const bool has_colors = colors.cols() == positions_m.cols();
  for (int i = 0; i < grid.particleCount(); ++i) {
    const std::uint32_t rgb = packRgb(has_colors ? Eigen::Vector3f(colors.col(i)) : Eigen::Vector3f::Ones());
    const bool inside = grid.isActive(i);
    float values[4] = {inside ? static_cast<float>(positions_m(0, i)) : kInvalid,
                       inside ? static_cast<float>(positions_m(1, i)) : kInvalid,
                       inside ? static_cast<float>(positions_m(2, i)) : kInvalid, 0.0f};
    std::memcpy(&values[3], &rgb, sizeof(float));  // rviz reads the rgb float's bits as 0x00RRGGBB
    writeFloats(&cloud.data[static_cast<std::size_t>(i) * kPointStep], values, 4);
  }
  return cloud;
}

sensor_msgs::Image toDepthImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp) {
  sensor_msgs::Image image =
      emptyImage(frame, sensor_msgs::image_encodings::TYPE_32FC1, kFloatBytes, optical_frame, stamp);
  image.data.resize(frame.depth_m.size() * kFloatBytes);
  std::memcpy(image.data.data(), frame.depth_m.data(), image.data.size());
  return image;
}

sensor_msgs::Image toMaskImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp) {
  sensor_msgs::Image image = emptyImage(frame, sensor_msgs::image_encodings::MONO8, 1, optical_frame, stamp);
  image.data = frame.mask;
  return image;
}

sensor_msgs::Image toColorImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp) {
  sensor_msgs::Image image = emptyImage(frame, sensor_msgs::image_encodings::RGB8, 3, optical_frame, stamp);
  image.data = frame.rgb;
  return image;
}

sensor_msgs::CameraInfo toCameraInfo(const core::PinholeCamera& camera, const std::string& optical_frame,
                                     const ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = optical_frame;
  info.header.stamp = stamp;
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);
  info.K = {camera.fx_px, 0.0, camera.cx_px, 0.0, camera.fy_px, camera.cy_px, 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx_px, 0.0, camera.cx_px, 0.0, 0.0, camera.fy_px, camera.cy_px, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

sensor_msgs::PointCloud2 toDepthCloud(const core::DepthFrame& frame, const core::PinholeCamera& camera,
                                      const std::string& optical_frame, const ros::Time& stamp) {
  sensor_msgs::PointCloud2 cloud = emptyCloud(frame.width, frame.height, false, optical_frame, stamp);
  cloud.is_dense = false;
  // As depth_image_proc computes it (depth_conversions.h): float centre and 1 / f, times the float depth.
  const float center_x = static_cast<float>(camera.cx_px);
  const float center_y = static_cast<float>(camera.cy_px);
  const float constant_x = static_cast<float>(1.0 / camera.fx_px);
  const float constant_y = static_cast<float>(1.0 / camera.fy_px);
  const float nothing = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < frame.height; ++v) {
    for (int u = 0; u < frame.width; ++u) {
      const std::size_t pixel = static_cast<std::size_t>(v) * frame.width + u;
      const float depth_m = frame.depth_m[pixel];
      float values[3] = {nothing, nothing, nothing};
      if (std::isfinite(depth_m)) {
        values[0] = (u - center_x) * depth_m * constant_x;
        values[1] = (v - center_y) * depth_m * constant_y;
        values[2] = depth_m;
      }
      writeFloats(&cloud.data[pixel * kPointStep], values, 3);
    }
  }
  return cloud;
}

}  // namespace cloth_sim
