#include "cloth_sim/ros/conversions.h"

#include "cloth_sim/io/scene_file.h"  // kCoreTagPrefix
#include "cloth_sim/ros/drawable.h"

#include <Eigen/Geometry>
#include <ros/param.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace cloth_sim {

namespace {

std_msgs::Header header(const std::string& frame_id, const ros::Time& stamp) {
  std_msgs::Header h;
  h.frame_id = frame_id;
  h.stamp = stamp;
  return h;
}

/// A message with fields x, y, z (a Point, a Vector3) from a vector.
template <typename Xyz>
Xyz toXyz(const Eigen::Vector3d& v) {
  Xyz out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

std_msgs::ColorRGBA toColor(const Eigen::Vector3f& rgb) {
  std_msgs::ColorRGBA color;
  color.r = rgb.x();
  color.g = rgb.y();
  color.b = rgb.z();
  color.a = 1.0f;
  return color;
}

/// Drawn size of a plane collider (planes are infinite), m, and the thickness of the slab drawn for it.
constexpr double kPlaneDrawnSide_m = 4.0;
constexpr double kPlaneDrawnThickness_m = 0.005;
/// Colliders are drawn this far inside their true surface, m: cloth resting on a surface drawn exactly
/// there flickers through it in rviz (z-fighting).
constexpr double kDrawnInset_m = 0.01;
/// Smallest drawn size, m: a collider thinner than twice the inset still shows (rviz rejects scale <= 0).
constexpr double kMinDrawnSize_m = 0.002;
constexpr float kColliderAlpha = 0.6f;
/// Colliders are drawn mid grey, apart from the cloth's own colours.
constexpr float kColliderGrey = 0.55f;

visualization_msgs::Marker colliderMarker(const std::string& frame_id, const ros::Time& stamp, const std::string& ns,
                                          int id, int type, const Eigen::Vector3d& center_m,
                                          const Eigen::Quaterniond& orientation, const Eigen::Vector3d& size_m) {
  visualization_msgs::Marker marker;
  marker.header = header(frame_id, stamp);
  marker.ns = ns;
  marker.id = id;
  marker.type = type;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.position = toPoint(center_m);
  marker.pose.orientation.w = orientation.w();
  marker.pose.orientation.x = orientation.x();
  marker.pose.orientation.y = orientation.y();
  marker.pose.orientation.z = orientation.z();
  marker.scale.x = size_m.x();
  marker.scale.y = size_m.y();
  marker.scale.z = size_m.z();
  marker.color.r = marker.color.g = marker.color.b = kColliderGrey;
  marker.color.a = kColliderAlpha;
  return marker;
}

}  // namespace

visualization_msgs::MarkerArray toColliderMarkers(const core::Simulation& simulation, const std::string& frame_id,
                                                  const ros::Time& stamp, bool clear_first) {
  visualization_msgs::MarkerArray markers;
  if (clear_first) {
    visualization_msgs::Marker delete_all;
    delete_all.header = header(frame_id, stamp);
    delete_all.action = visualization_msgs::Marker::DELETEALL;
    markers.markers.push_back(delete_all);
  }
  const core::ColliderSet& colliders = simulation.options().colliders;
  const std::vector<Eigen::Vector3d> centers = simulation.sphereCenters();
  const Eigen::Quaterniond upright = Eigen::Quaterniond::Identity();
  for (std::size_t i = 0; i < centers.size(); ++i) {
    const double diameter_m = std::max(2.0 * (colliders.spheres[i].radius_m - kDrawnInset_m), kMinDrawnSize_m);
    markers.markers.push_back(colliderMarker(frame_id, stamp, "spheres", static_cast<int>(i),
                                             visualization_msgs::Marker::SPHERE, centers[i], upright,
                                             Eigen::Vector3d::Constant(diameter_m)));
  }
  for (std::size_t i = 0; i < colliders.boxes.size(); ++i) {
    const core::BoxCollider& box = colliders.boxes[i];
    markers.markers.push_back(colliderMarker(frame_id, stamp, "boxes", static_cast<int>(i),
                                             visualization_msgs::Marker::CUBE, 0.5 * (box.min_m + box.max_m), upright,
                                             (box.max_m - box.min_m - Eigen::Vector3d::Constant(2.0 * kDrawnInset_m))
                                                 .cwiseMax(kMinDrawnSize_m)));
  }
  // Links on tf frames, where their shapes stand now (a capsule as a cylinder and its two end spheres);
  // a link whose frame has not been seen yet is not drawn.
  int link_marker = 0;
  for (std::size_t i = 0; i < colliders.frames.size() && i < simulation.frameColliders().size(); ++i) {
    if (!simulation.frameColliders()[i].seen) continue;
    const core::FrameCollider& link = colliders.frames[i];
    const core::Pose pose = simulation.frameColliders()[i].track.atTime(simulation.state().time_s);
    const double diameter_m = std::max(2.0 * (link.radius_m - kDrawnInset_m), kMinDrawnSize_m);
    switch (link.shape) {
      case core::ShapeKind::kSphere:
        markers.markers.push_back(colliderMarker(frame_id, stamp, "frame_colliders", link_marker++,
                                                 visualization_msgs::Marker::SPHERE, pose.position_m, pose.orientation,
                                                 Eigen::Vector3d::Constant(diameter_m)));
        break;
      case core::ShapeKind::kCapsule:
        markers.markers.push_back(colliderMarker(frame_id, stamp, "frame_colliders", link_marker++,
                                                 visualization_msgs::Marker::CYLINDER, pose.position_m, pose.orientation,
                                                 Eigen::Vector3d(diameter_m, diameter_m, std::max(link.length_m, kMinDrawnSize_m))));
        for (const double end : {-0.5, 0.5}) {
          markers.markers.push_back(colliderMarker(
              frame_id, stamp, "frame_colliders", link_marker++, visualization_msgs::Marker::SPHERE,
              pose.transform(Eigen::Vector3d(0.0, 0.0, end * link.length_m)), pose.orientation,
              Eigen::Vector3d::Constant(diameter_m)));
        }
        break;
      case core::ShapeKind::kBox:
        markers.markers.push_back(colliderMarker(frame_id, stamp, "frame_colliders", link_marker++,
                                                 visualization_msgs::Marker::CUBE, pose.position_m, pose.orientation,
                                                 (link.size_m - Eigen::Vector3d::Constant(2.0 * kDrawnInset_m))
                                                     .cwiseMax(kMinDrawnSize_m)));
        break;
    }
  }
  for (std::size_t i = 0; i < colliders.planes.size(); ++i) {
    const core::PlaneCollider& plane = colliders.planes[i];
    // The slab's top face lies kDrawnInset_m under the plane, on the collider's side.
    const Eigen::Vector3d center_m =
        -plane.offset_m * plane.normal - (kDrawnInset_m + 0.5 * kPlaneDrawnThickness_m) * plane.normal;
    markers.markers.push_back(colliderMarker(
        frame_id, stamp, "planes", static_cast<int>(i), visualization_msgs::Marker::CUBE, center_m,
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), plane.normal),
        Eigen::Vector3d(kPlaneDrawnSide_m, kPlaneDrawnSide_m, kPlaneDrawnThickness_m)));
  }
  return markers;
}

visualization_msgs::Marker toMeshMarker(const core::Simulation& simulation, const std::string& frame_id,
                                        const ros::Time& stamp) {
  return toMeshMarker(simulation.grid(), simulation.state().positions_m, simulation.vertexColors(), frame_id, stamp);
}

visualization_msgs::Marker toMeshMarker(const core::ClothGrid& grid, const Eigen::Matrix3Xd& positions_m,
                                        const Eigen::Matrix3Xf& colors, const std::string& frame_id,
                                        const ros::Time& stamp) {
  visualization_msgs::Marker marker;
  marker.header = header(frame_id, stamp);
  marker.ns = "cloth";
  marker.id = 0;
  marker.type = visualization_msgs::Marker::TRIANGLE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = marker.scale.y = marker.scale.z = 1.0;  // TRIANGLE_LIST points are in metres as given
  marker.color.a = 1.0f;
  marker.points.reserve(grid.triangles.size());
  marker.colors.reserve(grid.triangles.size());
  for (int index : grid.triangles) {
    marker.points.push_back(toPoint(positions_m.col(index)));
    marker.colors.push_back(toColor(colors.col(index)));
  }
  return marker;
}

bool fromStateMessage(const cloth_sim::ClothState& message, int max_side, Eigen::Matrix3Xd* positions_m,
                      std::string* error) {
  std::vector<std::uint8_t> active;
  return fromStateMessage(message, max_side, positions_m, &active, error);
}

bool fromStateMessage(const cloth_sim::ClothState& message, int max_side, Eigen::Matrix3Xd* positions_m,
                      std::vector<std::uint8_t>* active, std::string* error) {
  if (std::string why = undrawableReason(message, max_side); !why.empty()) {
    *error = std::move(why);
    return false;
  }
  positions_m->resize(3, static_cast<Eigen::Index>(message.positions.size()));
  for (std::size_t i = 0; i < message.positions.size(); ++i) {
    const geometry_msgs::Point& p = message.positions[i];
    positions_m->col(static_cast<Eigen::Index>(i)) << p.x, p.y, p.z;
  }
  *active = message.active;
  return true;
}

cloth_sim::ClothState toStateMessage(const core::Simulation& simulation, const std::string& frame_id,
                                     const ros::Time& stamp) {
  cloth_sim::ClothState message;
  message.header = header(frame_id, stamp);
  message.rows = simulation.grid().rows;
  message.cols = simulation.grid().cols;
  const core::ClothState& state = simulation.state();
  message.positions.reserve(state.particleCount());
  message.velocities.reserve(state.particleCount());
  for (int i = 0; i < state.particleCount(); ++i) {
    message.positions.push_back(toPoint(state.positions_m.col(i)));
    message.velocities.push_back(toVector3(state.velocities_m_per_s.col(i)));
  }
  message.sim_time = state.time_s;
  message.frame = state.frame;
  message.integrator = core::integratorName(simulation.options().integrator);
  message.substeps = simulation.lastFrameSubsteps();
  message.active = simulation.grid().active;  // empty without an outline
  const core::EnergyReport energy = simulation.energies();
  message.kinetic_energy = energy.kinetic_J;
  message.potential_energy = energy.potential_J;
  return message;
}

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v) { return toXyz<geometry_msgs::Vector3>(v); }

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) { return toXyz<geometry_msgs::Point>(p); }

geometry_msgs::TransformStamped identityTransform(const std::string& parent_frame, const std::string& child_frame,
                                                  const ros::Time& stamp) {
  geometry_msgs::TransformStamped identity;
  identity.header.stamp = stamp;
  identity.header.frame_id = parent_frame;
  identity.child_frame_id = child_frame;
  identity.transform.rotation.w = 1.0;
  return identity;
}

std::vector<geometry_msgs::TransformStamped> toSphereTransforms(const core::Simulation& simulation,
                                                                const std::string& frame_id, const ros::Time& stamp,
                                                                const std::string& prefix) {
  std::vector<geometry_msgs::TransformStamped> transforms;
  const std::vector<Eigen::Vector3d> centers = simulation.sphereCenters();
  for (std::size_t i = 0; i < centers.size(); ++i) {
    geometry_msgs::TransformStamped t;
    t.header = header(frame_id, stamp);
    t.child_frame_id = prefix + std::to_string(i);
    t.transform.translation.x = centers[i].x();
    t.transform.translation.y = centers[i].y();
    t.transform.translation.z = centers[i].z();
    t.transform.rotation.w = 1.0;
    transforms.push_back(t);
  }
  return transforms;
}

core::GraspRequest toGraspRequest(const cloth_sim::Grasp& message, const Eigen::Vector3d& target_in_frame_m,
                                  const Eigen::Vector3d& force_in_frame_N) {
  core::GraspRequest request;
  request.id = message.id;
  request.particle = message.particle;
  request.target_m = target_in_frame_m;
  request.stiffness_N_per_m = message.stiffness;
  request.extra_force_N = force_in_frame_N;
  return request;
}

namespace {

/// A YAML scalar carrying the core-schema tag of the parameter's XmlRpc type, so that the scene-file
/// reader refuses a number where a string belongs (`_name:=42`) or a string where a number does.
template <typename T>
YAML::Node taggedScalar(const T& value, const char* type) {
  YAML::Node node(value);
  node.SetTag(std::string(core::kCoreTagPrefix) + type);
  return node;
}

/// Most characters of a parameter's value quoted in an error.
constexpr std::size_t kMaxQuotedValueChars = 32;

std::string describeParameter(const XmlRpc::XmlRpcValue& value) {
  XmlRpc::XmlRpcValue& v = const_cast<XmlRpc::XmlRpcValue&>(value);  // XmlRpc's accessors are not const
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v) ? "true (a bool)" : "false (a bool)";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v)) + " (an integer)";
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream out;
      out << static_cast<double>(v) << " (a number)";
      return out.str();
    }
    case XmlRpc::XmlRpcValue::TypeString: {
      const std::string text = v;
      return "'" + text.substr(0, kMaxQuotedValueChars) + (text.size() > kMaxQuotedValueChars ? "...'" : "'") +
             " (a string)";
    }
    case XmlRpc::XmlRpcValue::TypeArray:
      return "a list of " + std::to_string(v.size());
    case XmlRpc::XmlRpcValue::TypeStruct:
      return "a map";
    default:
      return "a value of XmlRpc type " + std::to_string(static_cast<int>(v.getType()));
  }
}

/// The member `name` of a parameter tree, or null when the tree is not a map or lacks it.
const XmlRpc::XmlRpcValue* member(const XmlRpc::XmlRpcValue& tree, const std::string& name) {
  XmlRpc::XmlRpcValue& t = const_cast<XmlRpc::XmlRpcValue&>(tree);
  if (t.getType() != XmlRpc::XmlRpcValue::TypeStruct || !t.hasMember(name)) return nullptr;
  return &t[name];
}

}  // namespace

XmlRpc::XmlRpcValue parameterTree(const std::string& ns) {
  XmlRpc::XmlRpcValue tree;
  if (!ros::param::get(ns, tree)) tree = XmlRpc::XmlRpcValue();
  return tree;
}

bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, std::string* value,
                       std::string* error) {
  const XmlRpc::XmlRpcValue* found = member(tree, name);
  if (!found) return true;
  if (found->getType() != XmlRpc::XmlRpcValue::TypeString) {
    *error = "parameter ~" + name + " = " + describeParameter(*found) + ": must be a string";
    return false;
  }
  *value = static_cast<std::string>(const_cast<XmlRpc::XmlRpcValue&>(*found));
  return true;
}

bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, double* value, std::string* error) {
  const XmlRpc::XmlRpcValue* found = member(tree, name);
  if (!found) return true;
  XmlRpc::XmlRpcValue& v = const_cast<XmlRpc::XmlRpcValue&>(*found);
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    *value = static_cast<double>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    *value = static_cast<int>(v);
  } else {
    *error = "parameter ~" + name + " = " + describeParameter(v) + ": must be a number";
    return false;
  }
  return true;
}

bool optionalParameter(const XmlRpc::XmlRpcValue& tree, const std::string& name, bool* value, std::string* error) {
  const XmlRpc::XmlRpcValue* found = member(tree, name);
  if (!found) return true;
  if (found->getType() != XmlRpc::XmlRpcValue::TypeBoolean) {
    *error = "parameter ~" + name + " = " + describeParameter(*found) + ": must be true or false";
    return false;
  }
  *value = static_cast<bool>(const_cast<XmlRpc::XmlRpcValue&>(*found));
  return true;
}

std::vector<std::string> nonFiniteFields(const cloth_sim::ClothState& message) {
  std::vector<std::string> fields;
  const auto finitePoint = [](double x, double y, double z) {
    return std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
  };
  if (!std::all_of(message.positions.begin(), message.positions.end(),
                   [&](const geometry_msgs::Point& p) { return finitePoint(p.x, p.y, p.z); })) {
    fields.push_back("positions");
  }
  if (!std::all_of(message.velocities.begin(), message.velocities.end(),
                   [&](const geometry_msgs::Vector3& v) { return finitePoint(v.x, v.y, v.z); })) {
    fields.push_back("velocities");
  }
  if (!std::isfinite(message.sim_time)) fields.push_back("sim_time");
  if (!std::isfinite(message.kinetic_energy)) fields.push_back("kinetic_energy");
  if (!std::isfinite(message.potential_energy)) fields.push_back("potential_energy");
  return fields;
}

void addFiniteValue(diagnostic_updater::DiagnosticStatusWrapper& status, const std::string& key, double value,
                    std::vector<std::string>* non_finite) {
  if (std::isfinite(value)) {
    status.add(key, value);
  } else {
    status.add(key, "not finite");
    non_finite->push_back(key);
  }
}

YAML::Node toYaml(const XmlRpc::XmlRpcValue& value) {
  XmlRpc::XmlRpcValue& v = const_cast<XmlRpc::XmlRpcValue&>(value);  // XmlRpc's accessors are not const
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return taggedScalar(static_cast<bool>(v), "bool");
    case XmlRpc::XmlRpcValue::TypeInt:
      return taggedScalar(static_cast<int>(v), "int");
    case XmlRpc::XmlRpcValue::TypeDouble:
      return taggedScalar(static_cast<double>(v), "float");
    case XmlRpc::XmlRpcValue::TypeString:
      return taggedScalar(static_cast<std::string>(v), "str");
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node list(YAML::NodeType::Sequence);
      for (int i = 0; i < v.size(); ++i) list.push_back(toYaml(v[i]));
      return list;
    }
    case XmlRpc::XmlRpcValue::TypeStruct: {
      YAML::Node map(YAML::NodeType::Map);
      for (auto& entry : v) map[entry.first] = toYaml(entry.second);
      return map;
    }
    default:
      return YAML::Node();  // invalid, date-time and binary values: left out, reported as "nothing"
  }
}

}  // namespace cloth_sim
