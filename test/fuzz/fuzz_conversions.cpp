// libFuzzer target: what arrives from other ROS nodes, through the conversions of src/ros/conversions.cpp
// into a small running Simulation. The input is a script of operations, each filled from the fuzz bytes
// (FuzzedDataProvider): a Grasp message (grab or release), a ClothState for the viewer, a parameter tree
// (XmlRpc, as ~ parameters and dynamic_reconfigure give it) retuning the cloth, and a frame advanced and
// turned into every message the node publishes. Refused input must say why; accepted input must leave
// every published number finite. Frames are advanced only after an input changed the cloth: an unchanged
// small cloth is the scene fuzzer's ground, and a frame is most of an execution's cost.
#include "cloth_sim/core/options.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/ros/conversions.h"
#include "fuzz_checks.h"

#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace {

namespace core = cloth_sim::core;
using cloth_sim::fuzz::require;

// Bounds that keep one execution in milliseconds.
constexpr int kMaxSide = 8;             ///< rows and cols of the simulated cloth
constexpr int kMaxOperations = 12;
constexpr std::size_t kMaxStatePoints = 300;  ///< positions in a fuzzed ClothState
constexpr int kMaxTreeDepth = 3;        ///< nesting of a fuzzed parameter tree
constexpr int kMaxTreeItems = 6;        ///< entries per list or map in it
constexpr int kMaxRetuneSubsteps = 16;
constexpr int kMaxRetuneSolverIterations = 100;

enum class Operation { kGrasp, kState, kParameters, kFrame, kCount };

/// A double that is often special: NaN, infinities, huge, tiny, or any bit pattern.
double consumeDouble(FuzzedDataProvider& input) {
  static const double kSpecial[] = {std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity(),
                                    std::numeric_limits<double>::max(),
                                    std::numeric_limits<double>::lowest(),
                                    std::numeric_limits<double>::denorm_min(),
                                    0.0, -0.0, 1e-300, 1e300, 1e4, 1e7};
  switch (input.ConsumeIntegralInRange<int>(0, 3)) {
    case 0:
      return input.PickValueInArray(kSpecial);
    case 1: {
      const std::uint64_t bits = input.ConsumeIntegral<std::uint64_t>();
      double value;
      std::memcpy(&value, &bits, sizeof value);
      return value;
    }
    default:
      return input.ConsumeFloatingPointInRange<double>(-10.0, 10.0);  // the sizes a cloth scene has
  }
}

geometry_msgs::Point consumePoint(FuzzedDataProvider& input) {
  geometry_msgs::Point p;
  p.x = consumeDouble(input);
  p.y = consumeDouble(input);
  p.z = consumeDouble(input);
  return p;
}

std_msgs::Header consumeHeader(FuzzedDataProvider& input) {
  std_msgs::Header header;
  header.seq = input.ConsumeIntegral<std::uint32_t>();
  header.stamp.sec = input.ConsumeIntegral<std::uint32_t>();
  header.stamp.nsec = input.ConsumeIntegral<std::uint32_t>();
  header.frame_id = input.ConsumeRandomLengthString(32);
  return header;
}

/// A parameter tree as XmlRpc hands it over: any type at any place, keys mostly the scene's.
XmlRpc::XmlRpcValue consumeParameter(FuzzedDataProvider& input, int depth) {
  const int type = input.ConsumeIntegralInRange<int>(0, depth < kMaxTreeDepth ? 5 : 3);
  switch (type) {
    case 0:
      return XmlRpc::XmlRpcValue(input.ConsumeBool());
    case 1:
      return XmlRpc::XmlRpcValue(input.ConsumeIntegral<int>());
    case 2:
      return XmlRpc::XmlRpcValue(consumeDouble(input));
    case 3:
      return XmlRpc::XmlRpcValue(input.ConsumeRandomLengthString(24));
    case 4: {
      XmlRpc::XmlRpcValue list;
      const int items = input.ConsumeIntegralInRange<int>(0, kMaxTreeItems);
      list.setSize(items);
      for (int i = 0; i < items; ++i) list[i] = consumeParameter(input, depth + 1);
      return list;
    }
    default: {
      XmlRpc::XmlRpcValue map;
      map.begin();  // an empty struct, not an invalid value
      const std::vector<std::string>& keys = core::sceneKeys();
      const int items = input.ConsumeIntegralInRange<int>(0, kMaxTreeItems);
      for (int i = 0; i < items; ++i) {
        const std::string key = input.ConsumeBool() ? keys[input.ConsumeIntegralInRange<std::size_t>(0, keys.size() - 1)]
                                                    : input.ConsumeRandomLengthString(16);
        map[key] = consumeParameter(input, depth + 1);
      }
      return map;
    }
  }
}

/// True when it changed the simulation's inputs (a grasp held or moved, or one let go).
bool grasp(FuzzedDataProvider& input, core::Simulation& simulation) {
  cloth_sim::Grasp message;
  message.header = consumeHeader(input);
  message.id = input.ConsumeIntegralInRange<std::uint32_t>(0, 20);
  message.action = input.ConsumeIntegral<std::uint8_t>();
  message.particle = input.ConsumeBool() ? input.ConsumeIntegral<std::int32_t>()
                                         : input.ConsumeIntegralInRange<std::int32_t>(-2, kMaxSide * kMaxSide);
  message.target = consumePoint(input);
  message.stiffness = consumeDouble(input);
  message.force.x = consumeDouble(input);
  message.force.y = consumeDouble(input);
  message.force.z = consumeDouble(input);
  if (message.action == cloth_sim::Grasp::RELEASE) return simulation.release(message.id);
  // The node expresses the target and the force in its frame first (tf); here the frames are the same.
  const core::GraspRequest request =
      cloth_sim::toGraspRequest(message, Eigen::Vector3d(message.target.x, message.target.y, message.target.z),
                                Eigen::Vector3d(message.force.x, message.force.y, message.force.z));
  std::string error;
  if (!simulation.grab(request, &error)) {
    require(!error.empty(), "grab refused without saying why");
    return false;
  }
  require(simulation.grasps().size() <= core::Simulation::kMaxGrasps, "more grasps held than allowed");
  for (const core::Grasp& held : simulation.grasps()) {
    require(held.target_m.allFinite() && held.extra_force_N.allFinite() && std::isfinite(held.stiffness_N_per_m),
            "an accepted grasp holds a non-finite value");
    require(held.particle >= 0 && held.particle < simulation.grid().particleCount(),
            "an accepted grasp holds a particle outside the grid");
  }
  return true;
}

/// What cloth_viewer does with a ClothState: check it, then draw it.
void viewState(FuzzedDataProvider& input) {
  cloth_sim::ClothState message;
  message.header = consumeHeader(input);
  const bool plausible = input.ConsumeBool();
  message.rows = plausible ? input.ConsumeIntegralInRange<std::uint32_t>(0, 20) : input.ConsumeIntegral<std::uint32_t>();
  message.cols = plausible ? input.ConsumeIntegralInRange<std::uint32_t>(0, 20) : input.ConsumeIntegral<std::uint32_t>();
  const std::size_t product = static_cast<std::size_t>(message.rows) * message.cols;
  const std::size_t count = input.ConsumeBool() && product <= kMaxStatePoints
                                ? product
                                : input.ConsumeIntegralInRange<std::size_t>(0, kMaxStatePoints);
  // Mostly ordinary positions, sometimes one bad value somewhere.
  message.positions.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    message.positions[i].x = static_cast<double>(i % 7);
    message.positions[i].y = static_cast<double>(i / 7);
  }
  const int bad_values = input.ConsumeIntegralInRange<int>(0, 3);
  for (int b = 0; b < bad_values && count > 0; ++b) {
    message.positions[input.ConsumeIntegralInRange<std::size_t>(0, count - 1)] = consumePoint(input);
  }
  const int max_side = input.ConsumeBool() ? core::OptionLimits::kMaxGridSide : input.ConsumeIntegral<int>();
  // The outline's flags: none (most states), one per particle, or any other length; any byte values.
  if (input.ConsumeBool()) {
    const std::size_t flags = input.ConsumeBool() ? count : input.ConsumeIntegralInRange<std::size_t>(0, kMaxStatePoints);
    message.active.resize(flags, 1);
    for (std::size_t i = 0; i < flags; ++i) message.active[i] = input.ConsumeBool() ? 1 : input.ConsumeIntegral<std::uint8_t>();
  }

  Eigen::Matrix3Xd positions_m;
  std::vector<std::uint8_t> active;
  std::string error;
  if (!cloth_sim::fromStateMessage(message, max_side, &positions_m, &active, &error)) {
    require(!error.empty(), "a ClothState refused without saying why");
    return;
  }
  require(message.rows >= 2 && message.cols >= 2 && static_cast<int>(message.rows) <= max_side &&
              static_cast<int>(message.cols) <= max_side,
          "a ClothState accepted with a side outside [2, max_side]");
  require(static_cast<std::size_t>(positions_m.cols()) == product, "accepted positions do not fill the grid");
  require(positions_m.allFinite(), "an accepted position is not finite");
  require(active.empty() || active.size() == product, "accepted flags do not fill the grid");
  require(std::all_of(active.begin(), active.end(), [](std::uint8_t a) { return a <= 1; }), "an accepted flag is not 0 or 1");
  const core::ClothGrid grid = core::buildClothGrid(static_cast<int>(message.rows), static_cast<int>(message.cols), 1.0,
                                                    1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                                    Eigen::Vector3d::UnitY(), active);
  const visualization_msgs::Marker mesh = cloth_sim::toMeshMarker(grid, positions_m, core::checkerColors(grid.uv),
                                                                  message.header.frame_id, message.header.stamp);
  for (const geometry_msgs::Point& p : mesh.points) {
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z), "a drawn point is not finite");
  }
}

/// ~ parameters and dynamic_reconfigure: a tree overlaid on the running options, validated, and
/// applied by retune (which refuses what would change the grid). True when retune took them.
bool retune(FuzzedDataProvider& input, core::Simulation& simulation) {
  const XmlRpc::XmlRpcValue tree = consumeParameter(input, 0);
  core::SceneOptions options = simulation.options();
  std::vector<std::string> errors;
  if (!core::applySceneYaml(cloth_sim::toYaml(tree), "parameter", &options, &errors)) {
    require(!errors.empty(), "parameters refused without saying why");
    return false;
  }
  if (!core::validateSceneOptions(options).empty()) return false;
  if (options.substeps > kMaxRetuneSubsteps || options.solver.max_iterations > kMaxRetuneSolverIterations) {
    return false;
  }
  std::string error;
  if (simulation.retune(options, &error)) return true;
  require(!error.empty(), "retune refused without saying why");
  return false;
}

bool isFinite(const geometry_msgs::Point& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

/// A frame, and every message the node makes of it.
void frame(core::Simulation& simulation) {
  const core::FrameReport report = simulation.advanceFrame();
  cloth_sim::fuzz::requireFiniteSimulation(simulation, report);
  const ros::Time stamp(1.0);
  const cloth_sim::ClothState state = cloth_sim::toStateMessage(simulation, "cloth", stamp);
  for (const geometry_msgs::Point& p : state.positions) require(isFinite(p), "a published position is not finite");
  for (const geometry_msgs::Vector3& v : state.velocities) {
    require(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z), "a published velocity is not finite");
  }
  require(std::isfinite(state.sim_time) && std::isfinite(state.kinetic_energy) && std::isfinite(state.potential_energy),
          "a published ClothState number is not finite");
  for (const geometry_msgs::Point& p : cloth_sim::toMeshMarker(simulation, "cloth", stamp).points) {
    require(isFinite(p), "a mesh point is not finite");
  }
  const visualization_msgs::MarkerArray colliders = cloth_sim::toColliderMarkers(simulation, "cloth", stamp, true);
  require(!colliders.markers.empty() && colliders.markers.front().action == visualization_msgs::Marker::DELETEALL,
          "the collider markers asked to clear the display first do not begin with a DELETEALL");
  for (const visualization_msgs::Marker& marker : cloth_sim::toColliderMarkers(simulation, "cloth", stamp, false).markers) {
    require(marker.action == visualization_msgs::Marker::ADD, "a collider marker is not an ADD");
    require(isFinite(marker.pose.position), "a collider marker's position is not finite");
    require(std::isfinite(marker.scale.x) && std::isfinite(marker.scale.y) && std::isfinite(marker.scale.z) &&
                marker.scale.x > 0.0 && marker.scale.y > 0.0 && marker.scale.z > 0.0,
            "a collider marker's scale is not finite and positive (rviz refuses it)");
  }
  for (const geometry_msgs::TransformStamped& t : cloth_sim::toSphereTransforms(simulation, "cloth", stamp,
                                                                                       cloth_sim::kDefaultSphereFramePrefix)) {
    require(std::isfinite(t.transform.translation.x) && std::isfinite(t.transform.translation.y) &&
                std::isfinite(t.transform.translation.z),
            "a sphere transform is not finite");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider input(data, size);
  core::SceneOptions options;  // the hanging scene, made small
  options.rows = input.ConsumeIntegralInRange<int>(2, kMaxSide);
  options.cols = input.ConsumeIntegralInRange<int>(2, kMaxSide);
  if (input.ConsumeBool()) options.colliders.spheres.push_back(core::SphereCollider{});
  if (input.ConsumeBool()) options.colliders.planes.push_back(core::PlaneCollider{});
  core::Simulation simulation(options);

  bool changed = false;  // since the last frame
  const int operations = input.ConsumeIntegralInRange<int>(1, kMaxOperations);
  for (int i = 0; i < operations && input.remaining_bytes() > 0; ++i) {
    switch (static_cast<Operation>(input.ConsumeIntegralInRange<int>(0, static_cast<int>(Operation::kCount) - 1))) {
      case Operation::kGrasp:
        changed = grasp(input, simulation) || changed;
        break;
      case Operation::kState:
        viewState(input);
        break;
      case Operation::kParameters:
        changed = retune(input, simulation) || changed;
        break;
      default:
        if (changed) frame(simulation);
        changed = false;
        break;
    }
  }
  if (changed) frame(simulation);
  return 0;
}
