#include "cloth_sim/ros/depth_cameras.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/ros/ros_time.h"
#include "cloth_sim/ros/sensor_conversions.h"

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2/exceptions.h>

#include <chrono>
#include <cmath>
#include <sstream>

namespace cloth_sim {

namespace {

constexpr double kWarnThrottle_s = 5.0;
constexpr std::uint32_t kQueueSize = 2;
/// An image counts as due this fraction of a simulated frame early (the frame timer jitters), so a
/// camera slower than the frame rate keeps its rate on average instead of slipping a tick each time.
constexpr double kDueTolerance_frames = 0.5;
using core::kMillisecondsPerSecond;

bool sameCamera(const core::CameraOptions& a, const core::CameraOptions& b) {
  return a.name == b.name && a.frame == b.frame && a.width == b.width && a.height == b.height && a.fx_px == b.fx_px &&
         a.fy_px == b.fy_px && a.cx_px == b.cx_px && a.cy_px == b.cy_px && a.rate_hz == b.rate_hz &&
         a.min_range_m == b.min_range_m && a.max_range_m == b.max_range_m && a.noise == b.noise && a.seed == b.seed;
}

bool sameCameras(const std::vector<core::CameraOptions>& a, const std::vector<core::CameraOptions>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!sameCamera(a[i], b[i])) return false;
  }
  return true;
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& transform) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::Quaterniond(transform.rotation.w, transform.rotation.x, transform.rotation.y,
                                     transform.rotation.z)
                      .normalized()
                      .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(transform.translation.x, transform.translation.y, transform.translation.z);
  return pose;
}

}  // namespace

struct DepthCameras::Camera {
  core::CameraOptions options;
  core::PinholeCamera pinhole;
  ros::Publisher depth_pub, info_pub, points_pub, mask_pub, color_pub;
  core::DepthRenderer renderer;
  core::DepthFrame frame;
  ros::Time next_due;      ///< zero: due at once
  ros::Time last_stamp;    ///< to notice time running backwards
  std::uint64_t images = 0;  ///< images rendered since the camera was configured
  double render_ms = 0.0;    ///< wall time of the last render, ms
  std::string problem;       ///< why the last due image was not rendered; empty when it was

  bool subscribed() const {
    return depth_pub.getNumSubscribers() > 0 || info_pub.getNumSubscribers() > 0 ||
           points_pub.getNumSubscribers() > 0 || mask_pub.getNumSubscribers() > 0 ||
           color_pub.getNumSubscribers() > 0;
  }
};

DepthCameras::DepthCameras(const ros::NodeHandle& private_handle, const tf2_ros::Buffer& tf_buffer,
                           std::string world_frame, const std::vector<core::CameraOptions>& cameras)
    : pnh_(private_handle), tf_buffer_(tf_buffer), world_frame_(std::move(world_frame)) {
  points_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>(SensorTopics::kPoints, kQueueSize);
  configure(cameras);
}

DepthCameras::~DepthCameras() = default;

void DepthCameras::configure(const std::vector<core::CameraOptions>& cameras) {
  cameras_.clear();
  for (const core::CameraOptions& options : cameras) {
    auto camera = std::make_unique<Camera>();
    camera->options = options;
    camera->pinhole = core::PinholeCamera::from(options);
    ros::NodeHandle handle(pnh_, options.name);
    camera->depth_pub = handle.advertise<sensor_msgs::Image>(SensorTopics::kDepthImage, kQueueSize);
    camera->info_pub = handle.advertise<sensor_msgs::CameraInfo>(SensorTopics::kDepthInfo, kQueueSize);
    camera->points_pub = handle.advertise<sensor_msgs::PointCloud2>(SensorTopics::kDepthPoints, kQueueSize);
    camera->mask_pub = handle.advertise<sensor_msgs::Image>(SensorTopics::kMask, kQueueSize);
    camera->color_pub = handle.advertise<sensor_msgs::Image>(SensorTopics::kColorImage, kQueueSize);
    cameras_.push_back(std::move(camera));
  }
  configured_ = cameras;
}

void DepthCameras::publish(const core::Simulation& simulation, const ros::Time& stamp) {
  if (!sameCameras(simulation.options().cameras, configured_)) configure(simulation.options().cameras);
  if (points_pub_.getNumSubscribers() > 0) {
    points_pub_.publish(toParticleCloud(simulation, world_frame_, stamp));
    ++clouds_built_;
  }
  for (const std::unique_ptr<Camera>& camera : cameras_) publishCamera(*camera, simulation, stamp);
}

void DepthCameras::publishCamera(Camera& camera, const core::Simulation& simulation, const ros::Time& stamp) {
  if (stamp < camera.last_stamp) camera.next_due = ros::Time();  // time ran backwards: due at once
  camera.last_stamp = stamp;
  if (!camera.subscribed()) {
    camera.next_due = ros::Time();  // the first image comes as soon as someone subscribes
    return;
  }
  const double period_s = 1.0 / camera.options.rate_hz;
  const double tolerance_s = kDueTolerance_frames * simulation.options().frameDuration_s();
  if (!camera.next_due.isZero() && secondsBetween(stamp, camera.next_due) > tolerance_s) return;
  // Due times advance by whole periods (the average rate is the camera's), restarting after a long gap.
  const bool fell_behind = camera.next_due.isZero() || secondsBetween(camera.next_due, stamp) > period_s;
  camera.next_due = (fell_behind ? stamp : camera.next_due) + ros::Duration(period_s);

  Eigen::Isometry3d world_from_optical;
  if (!lookupPose(camera, stamp, &world_from_optical, &camera.problem)) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: camera '%s' not rendered: %s", camera.options.name.c_str(),
                      camera.problem.c_str());
    return;
  }
  camera.problem.clear();
  const auto start = std::chrono::steady_clock::now();
  core::RenderScene scene;
  scene.positions_m = &simulation.state().positions_m;
  scene.triangles = &simulation.grid().triangles;
  scene.colors = &simulation.vertexColors();
  scene.colliders = &simulation.options().colliders;
  scene.time_s = simulation.state().time_s;
  scene.collider_inset_m = core::colliderInset_m(simulation.options().contact);
  const bool with_color = camera.color_pub.getNumSubscribers() > 0;
  camera.renderer.render(camera.pinhole, world_from_optical, scene, with_color, &camera.frame);
  if (camera.options.noise == core::DepthNoise::kKinect) {
    core::addKinectNoise(camera.options.seed, simulation.state().frame, camera.pinhole, &camera.frame);
  }
  camera.render_ms =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() * kMillisecondsPerSecond;
  ++camera.images;

  const std::string& optical = camera.options.frame;
  // The info goes with every image: image_transport's camera subscribers (depth_image_proc) pair them.
  camera.info_pub.publish(toCameraInfo(camera.pinhole, optical, stamp));
  if (camera.depth_pub.getNumSubscribers() > 0) camera.depth_pub.publish(toDepthImage(camera.frame, optical, stamp));
  if (camera.points_pub.getNumSubscribers() > 0) {
    camera.points_pub.publish(toDepthCloud(camera.frame, camera.pinhole, optical, stamp));
  }
  if (camera.mask_pub.getNumSubscribers() > 0) camera.mask_pub.publish(toMaskImage(camera.frame, optical, stamp));
  if (with_color) camera.color_pub.publish(toColorImage(camera.frame, optical, stamp));
}

bool DepthCameras::lookupPose(const Camera& camera, const ros::Time& stamp, Eigen::Isometry3d* world_from_optical,
                              std::string* problem) const {
  const std::string& frame = camera.options.frame;
  geometry_msgs::TransformStamped transform;
  try {
    // Asked first without a message: tf2 writes the message of an extrapolation with a ros::Duration, which
    // throws std::runtime_error (not a tf2 exception) when the image's time lies 2^31 s or more past tf's data.
    if (tf_buffer_.canTransform(world_frame_, frame, stamp)) {
      transform = tf_buffer_.lookupTransform(world_frame_, frame, stamp);
    } else {
      // Usually the robot's newest pose is a little older than the frame: take it if it is recent.
      transform = tf_buffer_.lookupTransform(world_frame_, frame, ros::Time(0));
      // Usually older than the image; newer only when the image's time is before tf's buffer (then the
      // pose is as far from the image's time the other way).
      const double age_s = secondsBetween(transform.header.stamp, stamp);
      if (std::abs(age_s) > kMaxPoseAge_s) {
        std::ostringstream out;
        out << "the newest pose of frame '" << frame << "' is " << age_s << " s away from the image's time (at most "
            << kMaxPoseAge_s << " s)";
        *problem = out.str();
        return false;
      }
    }
  } catch (const tf2::TransformException& e) {
    *problem = "no pose for frame '" + frame + "' in '" + world_frame_ + "': " + e.what();
    return false;
  }
  *world_from_optical = toIsometry(transform.transform);
  return true;
}

void DepthCameras::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  std::string problems;
  for (const std::unique_ptr<Camera>& camera : cameras_) {
    const std::string& name = camera->options.name;
    status.add(name + " frame", camera->options.frame);
    status.add(name + " images", camera->images);
    status.add(name + " render cost [ms]", camera->render_ms);
    if (!camera->problem.empty()) {
      problems += (problems.empty() ? "" : "; ") + ("camera '" + name + "': " + camera->problem);
    }
  }
  status.add("point clouds built", clouds_built_);
  if (problems.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, std::to_string(cameras_.size()) + " cameras");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problems);
  }
}

}  // namespace cloth_sim
