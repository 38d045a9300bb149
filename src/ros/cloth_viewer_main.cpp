// cloth_viewer: turns ClothState messages (live, or from a compact recording) back into the cloth's rviz
// mesh, so that a recording, or a viewer on another machine, needs only the state: about a sixth of the
// mesh marker's bytes (each vertex once, no colours, against six times with colours).
//
//   rosrun cloth_sim cloth_viewer [_state_topic:=/cloth_node/state] [_mesh_topic:=mesh] [_mesh_rate:=25]
//                                 [_publish_mesh:=true] [_parent_frame_id:=map _frame_id:=world]
//
// The mesh is drawn with the built-in checker colours (a state message carries no texture).
// With ~parent_frame_id set, it also publishes ~frame_id as a static identity child of it in tf, as the live
// node does (its own ~parent_frame_id): a recording holds no static tf, and without one rviz has no fixed
// frame to draw in and leaves its Global Status at Warn. playback.launch does that, with publish_mesh:=false
// unless a Marker display wants the mesh (the ClothState rviz display draws the state itself).
#include "cloth_sim/ClothState.h"
#include "cloth_sim/core/grid.h"
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/ros/conversions.h"
#include "cloth_sim/ros/mesh_schedule.h"

#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <visualization_msgs/Marker.h>

#include <cmath>
#include <cstdint>
#include <string>

namespace {

constexpr double kWarnThrottle_s = 5.0;
/// Meshes per second at most by default: the node's frame rate.
constexpr double kDefaultMeshRateHz = 50.0;
/// States the subscriber holds: cloth_node sends the frames a late timer tick catches up on back to back
/// (up to 6, its own ~state queue), and the mesh is scheduled by their stamps, so none is dropped.
constexpr std::uint32_t kStateQueue = 6;
/// A state up to this many state periods before its mesh is due counts as on time.
constexpr double kEarlyStatePeriods = 0.5;
/// Unit grid the topology is built on: only its triangles and texture coordinates are used.
constexpr double kUnitSide_m = 1.0;

class ClothViewer {
 public:
  bool start(std::string* error) {
    ros::NodeHandle pnh("~");
    std::string state_topic = "/cloth_node/state";
    std::string mesh_topic = "mesh";
    double mesh_rate_hz = kDefaultMeshRateHz;
    std::string frame_id = "world";
    std::string parent_frame;
    // Each of the wrong type is refused by name (ros::param would fall back to its default in silence).
    const XmlRpc::XmlRpcValue tree = cloth_sim::parameterTree(pnh.getNamespace());
    if (!cloth_sim::optionalParameter(tree, "state_topic", &state_topic, error) ||
        !cloth_sim::optionalParameter(tree, "mesh_topic", &mesh_topic, error) ||
        !cloth_sim::optionalParameter(tree, "mesh_rate", &mesh_rate_hz, error) ||
        !cloth_sim::optionalParameter(tree, "publish_mesh", &publish_mesh_, error) ||
        !cloth_sim::optionalParameter(tree, "frame_id", &frame_id, error) ||
        !cloth_sim::optionalParameter(tree, "parent_frame_id", &parent_frame, error)) {
      return false;
    }
    if (state_topic.empty() || mesh_topic.empty()) {
      *error = "parameters ~state_topic = '" + state_topic + "', ~mesh_topic = '" + mesh_topic + "': must name topics";
      return false;
    }
    // Resolved here, where an invalid name (9bad, a%b, ~state: NodeHandles take no ~ names) is refused by
    // name: subscribe() and advertise() would throw ros::InvalidNameException and abort the viewer.
    ros::NodeHandle nh;
    if (!resolveTopic(nh, "state_topic", &state_topic, error) || !resolveTopic(pnh, "mesh_topic", &mesh_topic, error)) {
      return false;
    }
    // Checked with or without a mesh to publish (a bad value is a mistake either way, and would bite when
    // the mesh is switched back on), and before anything is sent: a refused start sends no tf.
    if (!std::isfinite(mesh_rate_hz) || mesh_rate_hz <= 0.0 ||
        mesh_rate_hz > cloth_sim::core::OptionLimits::kMaxFrameRateHz) {
      *error = "parameter ~mesh_rate = " + std::to_string(mesh_rate_hz) + ": must be in (0, " +
               std::to_string(cloth_sim::core::OptionLimits::kMaxFrameRateHz) + "] Hz";
      return false;
    }
    if (!parent_frame.empty()) {
      if (frame_id.empty() || frame_id[0] == '/' || parent_frame[0] == '/' || parent_frame == frame_id) {
        *error = "parameters ~frame_id = '" + frame_id + "', ~parent_frame_id = '" + parent_frame +
                 "': must be two different tf frame names without a leading '/'";
        return false;
      }
      // Static: valid at every time, so also at a looping bag's /clock.
      static_broadcaster_.sendTransform(cloth_sim::identityTransform(parent_frame, frame_id, ros::Time::now()));
      ROS_INFO("cloth_viewer: tf %s -> %s (static identity)", parent_frame.c_str(), frame_id.c_str());
    }
    if (!publish_mesh_) return true;
    mesh_schedule_ = cloth_sim::MeshSchedule(mesh_rate_hz);
    mesh_pub_ = pnh.advertise<visualization_msgs::Marker>(mesh_topic, 2);
    state_sub_ = nh.subscribe(state_topic, kStateQueue, &ClothViewer::onState, this);
    ROS_INFO("cloth_viewer: %s -> %s at most %.0f Hz", state_sub_.getTopic().c_str(), mesh_pub_.getTopic().c_str(),
             mesh_rate_hz);
    return true;
  }

 private:
  /// *topic resolved in handle's namespace, or false with *error naming the parameter and why.
  static bool resolveTopic(const ros::NodeHandle& handle, const char* parameter, std::string* topic,
                           std::string* error) {
    std::string resolved;
    try {
      resolved = handle.resolveName(*topic);
    } catch (const ros::InvalidNameException& e) {
      *error = std::string("parameter ~") + parameter + " = '" + *topic + "': not a valid topic name (" + e.what() + ")";
      return false;
    }
    if (resolved.empty() || resolved == "/") {
      *error = std::string("parameter ~") + parameter + " = '" + *topic + "': names the root namespace, not a topic";
      return false;
    }
    *topic = resolved;
    return true;
  }

  void onState(const cloth_sim::ClothState::ConstPtr& message) {
    const ros::Time stamp = message->header.stamp;
    // In seconds as doubles: ros::Time's own difference throws (and would end the viewer) when a peer's
    // stamp lies more than 2^31 s from the last one.
    // An unstamped state (zero) is scheduled by the viewer's own clock: by its zero stamp it would be due
    // once and then never again.
    const double stamp_s = stamp.isZero() ? ros::Time::now().toSec() : stamp.toSec();
    const double state_period_s = stamp_s - last_state_s_;
    last_state_s_ = stamp_s;
    // Half the states' own period early counts as on time, as the node does with its frames (their
    // stamps jitter by tens of microseconds).
    const double early_s = state_period_s > 0.0 ? kEarlyStatePeriods * state_period_s : 0.0;
    // Converted before it is scheduled: a state that cannot be drawn must not take a mesh's turn (it did,
    // and the well-formed state after it then waited a whole period).
    std::string error;
    if (!cloth_sim::fromStateMessage(*message, cloth_sim::core::OptionLimits::kMaxGridSide, &positions_m_, &active_,
                                     &error)) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_viewer: dropped a ClothState: %s", error.c_str());
      return;
    }
    if (!mesh_schedule_.due(stamp_s, early_s)) return;
    // The particles outside an outline are left out of the mesh, as the node's own ~mesh does.
    if (grid_.rows != static_cast<int>(message->rows) || grid_.cols != static_cast<int>(message->cols) ||
        grid_.active != active_) {
      grid_ = cloth_sim::core::buildClothGrid(static_cast<int>(message->rows), static_cast<int>(message->cols),
                                              kUnitSide_m, kUnitSide_m, Eigen::Vector3d::Zero(),
                                              Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), active_);
      colors_ = cloth_sim::core::checkerColors(grid_.uv);
    }
    mesh_pub_.publish(cloth_sim::toMeshMarker(grid_, positions_m_, colors_, message->header.frame_id, stamp));
  }

  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  bool publish_mesh_ = true;
  ros::Publisher mesh_pub_;
  ros::Subscriber state_sub_;
  cloth_sim::MeshSchedule mesh_schedule_{kDefaultMeshRateHz};
  double last_state_s_ = 0.0;  ///< the last state's stamp, s
  cloth_sim::core::ClothGrid grid_;  ///< topology of the last grid size seen
  Eigen::Matrix3Xf colors_;
  Eigen::Matrix3Xd positions_m_;
  std::vector<std::uint8_t> active_;  ///< the last state's particles that are cloth (empty: all)
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloth_viewer");
  ClothViewer viewer;
  std::string error;
  if (!viewer.start(&error)) {
    ROS_FATAL("cloth_viewer: %s", error.c_str());
    return 1;
  }
  ros::spin();
  return 0;
}
