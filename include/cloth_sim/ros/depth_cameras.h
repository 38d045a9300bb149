// The node's sensors: ~points (one point per particle) and the scene's simulated depth cameras, each
// posed from tf at the image's time and rendered by core::DepthRenderer. Everything here runs on the
// node's spin thread, from ClothNode::publish, and builds a message only while someone subscribes to it.
#pragma once

#include "cloth_sim/core/depth_render.h"
#include "cloth_sim/core/simulation.h"

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cloth_sim {

/// Topic names, under the node's private namespace; a camera's are under ~<name>/.
struct SensorTopics {
  static constexpr const char* kPoints = "points";
  static constexpr const char* kDepthImage = "depth/image_raw";
  static constexpr const char* kDepthInfo = "depth/camera_info";
  static constexpr const char* kDepthPoints = "depth/points";
  static constexpr const char* kMask = "mask";
  static constexpr const char* kColorImage = "rgb/image_raw";
};

class DepthCameras {
 public:
  /// When tf has no pose at the image's time (a robot's frames arrive after the frame's time), its newest
  /// pose is used if it is within this much of the image's time; otherwise the image is dropped.
  static constexpr double kMaxPoseAge_s = 0.1;

  /// world_frame: the simulation's frame (~frame_id); tf_buffer must outlive this object. The cameras'
  /// topics are advertised at once (under /use_sim_time nothing is published before the first /clock).
  DepthCameras(const ros::NodeHandle& private_handle, const tf2_ros::Buffer& tf_buffer, std::string world_frame,
               const std::vector<core::CameraOptions>& cameras);
  ~DepthCameras();

  /// Publishes what is due and subscribed at `stamp`: ~points every call, each camera at its rate. The
  /// cameras follow the simulation's options (a new scene or state file re-creates their topics).
  void publish(const core::Simulation& simulation, const ros::Time& stamp);

  /// Counts (clouds and images built), each camera's last render cost, and any camera without a pose.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

 private:
  struct Camera;
  void configure(const std::vector<core::CameraOptions>& cameras);
  /// The camera's optical frame in the world at `stamp`, or false with the reason.
  bool lookupPose(const Camera& camera, const ros::Time& stamp, Eigen::Isometry3d* world_from_optical,
                  std::string* problem) const;
  void publishCamera(Camera& camera, const core::Simulation& simulation, const ros::Time& stamp);

  ros::NodeHandle pnh_;
  const tf2_ros::Buffer& tf_buffer_;
  std::string world_frame_;
  ros::Publisher points_pub_;
  std::vector<core::CameraOptions> configured_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::uint64_t clouds_built_ = 0;  ///< ~points messages built since start-up
};

}  // namespace cloth_sim
