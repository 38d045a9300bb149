// Every conversion between the ROS-free core and ROS messages/parameters lives here, so a topic change
// never touches the physics and a physics change never touches the node.
#pragma once

#include "cloth_sim/ClothState.h"
#include "cloth_sim/Grasp.h"
#include "cloth_sim/core/simulation.h"

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>
#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <string>
#include <vector>

namespace cloth_sim {

/// The cloth as an rviz TRIANGLE_LIST: two triangles per grid quad, 6 (rows-1)(cols-1) points, one
/// colour per point (per-vertex texture colours, Gouraud-shaded by rviz).
visualization_msgs::Marker toMeshMarker(const core::Simulation& simulation, const std::string& frame_id,
                                        const ros::Time& stamp);
/// The same from a grid's topology, positions (3 x N, m) and colours (3 x N, RGB in [0, 1]): what
/// cloth_viewer draws from a ClothState.
visualization_msgs::Marker toMeshMarker(const core::ClothGrid& grid, const Eigen::Matrix3Xd& positions_m,
                                        const Eigen::Matrix3Xf& colors, const std::string& frame_id,
                                        const ros::Time& stamp);

/// Positions of a ClothState as a 3 x N array; false with *error (naming what is wrong) when rows, cols and
/// the position count disagree, the grid is outside [2, max_side] per side, or a position cannot be drawn
/// (not finite, or beyond kMaxDrawnCoordinate_m on an axis: cloth_sim/ros/drawable.h).
bool fromStateMessage(const cloth_sim::ClothState& message, int max_side, Eigen::Matrix3Xd* positions_m,
                      std::string* error);
/// The same, and the particles that are cloth (`active`: empty when every particle is, else one 0 or 1 per
/// particle, as core::ClothGrid::active); false with *error when `active` has another length or value.
bool fromStateMessage(const cloth_sim::ClothState& message, int max_side, Eigen::Matrix3Xd* positions_m,
                      std::vector<std::uint8_t>* active, std::string* error);

/// The whole state after a frame, with energies and the integrator in use.
cloth_sim::ClothState toStateMessage(const core::Simulation& simulation, const std::string& frame_id,
                                     const ros::Time& stamp);

/// The colliders as rviz shapes at the current time, drawn 1 cm inside their surfaces (no z-fighting with
/// the cloth resting on them): spheres, boxes, and planes as 4 m square slabs
/// centred on the point of the plane nearest the origin, and the frame colliders where their shapes stand (a
/// capsule as a cylinder and two end spheres). Namespaces "spheres", "boxes", "planes", "frame_colliders".
/// With `clear_first` the first marker is a DELETEALL: a display keeps every marker it was sent, so after a
/// scene with more colliders than this one (~load_scene, ~load_state) the old ones stay drawn unless
/// deleted. Only then: every tick it would make rviz rebuild every shape.
visualization_msgs::MarkerArray toColliderMarkers(const core::Simulation& simulation, const std::string& frame_id,
                                                  const ros::Time& stamp, bool clear_first);

/// A vector (a velocity, a force, a torque) as a message.
geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v);
/// A point (m) as a message.
geometry_msgs::Point toPoint(const Eigen::Vector3d& p);

/// child_frame at parent_frame's origin, unrotated: the static tf that places the cloth's frame in a
/// parent frame (the node's and the viewer's ~parent_frame_id).
geometry_msgs::TransformStamped identityTransform(const std::string& parent_frame, const std::string& child_frame,
                                                  const ros::Time& stamp);

/// The sphere colliders' tf frames unless ~sphere_frame_prefix says otherwise: sphere_0, sphere_1, ...
inline constexpr const char* kDefaultSphereFramePrefix = "sphere_";

/// tf frames <prefix><i>, children of frame_id, at the spheres' current centres.
std::vector<geometry_msgs::TransformStamped> toSphereTransforms(const core::Simulation& simulation,
                                                                const std::string& frame_id, const ros::Time& stamp,
                                                                const std::string& prefix);

/// A GRAB message as a core request; its target and force (given in header.frame_id) must already be
/// expressed in the simulation's frame (the force rotated only: a free vector).
core::GraspRequest toGraspRequest(const cloth_sim::Grasp& message, const Eigen::Vector3d& target_in_frame_m,
                                  const Eigen::Vector3d& force_in_frame_N);

/// A parameter tree (as XmlRpc gives it) as YAML, so parameters and scene files share one parser. Each
/// scalar carries the YAML tag of its XmlRpc type (!!bool, !!int, !!float, !!str), and the scene-file
/// reader refuses a tag that does not fit the key: a parameter's type is checked there, once.
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);

/// Every parameter under `ns` (a node's private namespace) as one tree, read once; an empty value where
/// there is none, so optionalParameter finds each absent.
XmlRpc::XmlRpcValue parameterTree(const std::string& ns);

/// The node's own (non-scene) parameters, read from the private namespace's tree. Absent: *value is left
/// as it is (the default) and true. Present with another XmlRpc type (`_scene:=42`, a list for
/// ~frame_id): false with *error naming the parameter, what it got and the type expected. The double
/// overload accepts integers; the bool one only true or false (not 0 or 1).
bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, std::string* value,
                       std::string* error);
bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, double* value, std::string* error);
bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, bool* value, std::string* error);

/// The ClothState fields holding a non-finite number ("positions", "velocities", "sim_time",
/// "kinetic_energy", "potential_energy"); empty when it may be published.
std::vector<std::string> nonFiniteFields(const cloth_sim::ClothState& message);

/// Adds a number to a diagnostics status, or "not finite" (and `key` to *non_finite) when it is not.
void addFiniteValue(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& key, double value,
                    std::vector<std::string>* non_finite);

}  // namespace cloth_sim
