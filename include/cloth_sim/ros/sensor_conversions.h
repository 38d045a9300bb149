// Conversions from the core to sensor_msgs: the particle cloud and the simulated cameras' images. Kept
// beside conversions.h (the core <-> marker/state/parameter conversions) in a file of their own, so the
// sensor topics change in one place.
#pragma once

#include "cloth_sim/core/depth_render.h"
#include "cloth_sim/core/simulation.h"

#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include <string>

namespace cloth_sim {

/// One point per particle, organised as the grid (height = rows, width = cols), in frame_id: fields x, y, z
/// (float32, m) and rgb (the vertex colour packed as rviz reads it: a float32 holding 0x00RRGGBB).
sensor_msgs::PointCloud2 toParticleCloud(const core::Simulation& simulation, const std::string& frame_id,
                                         const ros::Time& stamp);

/// The depth image, encoding 32FC1, metres along the optical axis, NaN where nothing is seen.
sensor_msgs::Image toDepthImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp);
/// The cloth mask, encoding mono8, 255 where the cloth is the surface seen.
sensor_msgs::Image toMaskImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp);
/// The shaded colour image, encoding rgb8 (frame.rgb must be filled).
sensor_msgs::Image toColorImage(const core::DepthFrame& frame, const std::string& optical_frame, const ros::Time& stamp);

/// The pinhole model as CameraInfo: plumb_bob with zero distortion, K and P from fx, fy, cx, cy, R = I.
sensor_msgs::CameraInfo toCameraInfo(const core::PinholeCamera& camera, const std::string& optical_frame,
                                     const ros::Time& stamp);

/// The depth image as an organised cloud (width x height, fields x, y, z float32, point_step 16), NaN where
/// nothing is seen: x = (u - cx) z / fx, y = (v - cy) z / fy, the same formula as depth_image_proc's
/// point_cloud_xyz, so the two agree to float precision.
sensor_msgs::PointCloud2 toDepthCloud(const core::DepthFrame& frame, const core::PinholeCamera& camera,
                                      const std::string& optical_frame, const ros::Time& stamp);

}  // namespace cloth_sim
