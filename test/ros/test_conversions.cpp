// The node's conversions on their own (no master needed): a parameter of the wrong type is refused by
// name instead of falling back to a default, no non-finite number is let out to be published, and a
// state message from another node is checked before it is drawn.
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/ros/conversions.h"
#include "cloth_sim/ros/drawable.h"
#include "cloth_sim/ros/grasp_queue.h"
#include "cloth_sim/ros/ros_time.h"
#include "cloth_sim/ros/sensor_conversions.h"

#include <boost/make_shared.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace cloth_sim {
namespace {

bool mentions(const std::string& text, const std::string& needle) { return text.find(needle) != std::string::npos; }

/// Applies one parameter (as the parameter server would hand it over) to the default options.
std::string overlayError(const std::string& key, const XmlRpc::XmlRpcValue& value) {
  YAML::Node overlay(YAML::NodeType::Map);
  overlay[key] = toYaml(value);
  core::SceneOptions options;
  std::vector<std::string> errors;
  if (core::applySceneYaml(overlay, "parameter", &options, &errors)) return "";
  return errors.empty() ? "refused without a reason" : errors.front();
}

TEST(ParameterTypes, ASceneKeyGivenTheWrongXmlRpcTypeIsRefusedByName) {
  const std::string name_error = overlayError("name", XmlRpc::XmlRpcValue(42));
  EXPECT_TRUE(mentions(name_error, "name")) << name_error;
  EXPECT_TRUE(mentions(name_error, "a string")) << name_error;
  EXPECT_TRUE(mentions(overlayError("rows", XmlRpc::XmlRpcValue(std::string("5"))), "an integer"));
  EXPECT_TRUE(mentions(overlayError("rows", XmlRpc::XmlRpcValue(5.0)), "an integer"));
  EXPECT_TRUE(mentions(overlayError("mass", XmlRpc::XmlRpcValue(std::string("0.5"))), "a number"));
  EXPECT_TRUE(mentions(overlayError("wind_enabled", XmlRpc::XmlRpcValue(1)), "true or false"));
  // What fits is taken: an integer for a number, integers and names mixed in a pin list.
  EXPECT_EQ(overlayError("mass", XmlRpc::XmlRpcValue(2)), "");
  EXPECT_EQ(overlayError("texture", XmlRpc::XmlRpcValue(std::string("cloth.png"))), "");
  XmlRpc::XmlRpcValue pins;
  pins[0] = 0;
  pins[1] = std::string("top_right");
  EXPECT_EQ(overlayError("pins", pins), "");
}

TEST(ParameterTypes, ANodeParameterOfTheWrongTypeIsRefusedAndAnAbsentOneKeepsItsDefault) {
  XmlRpc::XmlRpcValue tree;
  tree["scene"] = 42;
  tree["frame_id"][0] = std::string("a");
  tree["frame_id"][1] = std::string("b");
  tree["mesh_rate"] = 10;
  tree["parent_frame_id"] = std::string("map");
  std::string text = "default";
  std::string error;
  EXPECT_FALSE(optionalParameter(tree, "scene", &text, &error));
  EXPECT_TRUE(mentions(error, "~scene = 42 (an integer): must be a string")) << error;
  EXPECT_EQ(text, "default");
  EXPECT_FALSE(optionalParameter(tree, "frame_id", &text, &error));
  EXPECT_TRUE(mentions(error, "~frame_id = a list of 2: must be a string")) << error;
  double rate_hz = 0.0;
  EXPECT_TRUE(optionalParameter(tree, "mesh_rate", &rate_hz, &error));
  EXPECT_EQ(rate_hz, 10.0) << "an integer is a number";
  EXPECT_FALSE(optionalParameter(tree, "parent_frame_id", &rate_hz, &error));
  EXPECT_TRUE(mentions(error, "~parent_frame_id = 'map' (a string): must be a number")) << error;
  EXPECT_TRUE(optionalParameter(tree, "absent", &text, &error));
  EXPECT_EQ(text, "default");
  // A flag is true or false: 0 and 1 (roslaunch's reading of an untyped 0) are refused, not read as one.
  tree["publish_mesh"] = false;
  tree["record"] = 1;
  bool flag = true;
  EXPECT_TRUE(optionalParameter(tree, "publish_mesh", &flag, &error));
  EXPECT_FALSE(flag);
  EXPECT_FALSE(optionalParameter(tree, "record", &flag, &error));
  EXPECT_TRUE(mentions(error, "~record = 1 (an integer): must be true or false")) << error;
  EXPECT_FALSE(flag);
  flag = true;
  EXPECT_TRUE(optionalParameter(tree, "absent", &flag, &error));
  EXPECT_TRUE(flag) << "an absent flag keeps its default";
}

TEST(FiniteOutput, AStateWithANonFiniteNumberAnywhereIsFlaggedByField) {
  cloth_sim::ClothState state;
  state.positions.resize(4);
  state.velocities.resize(4);
  EXPECT_TRUE(nonFiniteFields(state).empty());
  state.kinetic_energy = std::numeric_limits<double>::infinity();  // pin_motion_period 1e-300 did this
  EXPECT_EQ(nonFiniteFields(state), std::vector<std::string>{"kinetic_energy"});
  state.kinetic_energy = 0.0;
  state.velocities[3].z = std::nan("");
  state.potential_energy = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(nonFiniteFields(state), (std::vector<std::string>{"velocities", "potential_energy"}));
  state.velocities[3].z = 0.0;
  state.potential_energy = 0.0;
  state.positions[0].x = std::nan("");
  state.sim_time = std::numeric_limits<double>::infinity();
  EXPECT_EQ(nonFiniteFields(state), (std::vector<std::string>{"positions", "sim_time"}));
}

TEST(FiniteOutput, ADiagnosticsValueThatIsNotFiniteIsWrittenAsTextAndNamed) {
  diagnostic_updater::DiagnosticStatusWrapper status;
  std::vector<std::string> non_finite;
  addFiniteValue(status, "kinetic energy [J]", std::numeric_limits<double>::infinity(), &non_finite);
  addFiniteValue(status, "max strain", 0.25, &non_finite);
  ASSERT_EQ(status.values.size(), 2u);
  EXPECT_EQ(status.values[0].value, "not finite");
  EXPECT_EQ(std::stod(status.values[1].value), 0.25);
  EXPECT_EQ(non_finite, std::vector<std::string>{"kinetic energy [J]"});
}

}  // namespace
}  // namespace cloth_sim

namespace {

cloth_sim::ClothState gridState(std::uint32_t rows, std::uint32_t cols) {
  cloth_sim::ClothState message;
  message.rows = rows;
  message.cols = cols;
  message.positions.resize(static_cast<std::size_t>(rows) * cols);
  return message;
}

TEST(FromStateMessage, AcceptsAGridWithinItsLimitsWithEveryPosition) {
  Eigen::Matrix3Xd positions_m;
  std::string error;
  cloth_sim::ClothState message = gridState(3, 4);
  message.positions[5].z = 2.5;
  ASSERT_TRUE(cloth_sim::fromStateMessage(message, 512, &positions_m, &error)) << error;
  EXPECT_EQ(positions_m.cols(), 12);
  EXPECT_EQ(positions_m(2, 5), 2.5);
}

// Found by fuzz_conversions: max_side went through a uint32 cast, so a negative one accepted any grid.
TEST(FromStateMessage, AMaxSideBelowTwoRefusesEveryGrid) {
  Eigen::Matrix3Xd positions_m;
  std::string error;
  for (int max_side : {-1, 0, 1, std::numeric_limits<int>::min()}) {
    EXPECT_FALSE(cloth_sim::fromStateMessage(gridState(3, 3), max_side, &positions_m, &error)) << max_side;
    EXPECT_NE(error.find("each must be in [2, " + std::to_string(max_side) + "]"), std::string::npos) << error;
  }
}

TEST(FromStateMessage, RefusesAPositionItCannotDraw) {
  // Not finite, or finite as a double but infinite as the float a marker holds (1e39: rviz aborted in
  // Ogre's bounding box, an audit found), or merely beyond kMaxDrawnCoordinate_m.
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 1e39,
                           -2 * cloth_sim::kMaxDrawnCoordinate_m}) {
    Eigen::Matrix3Xd positions_m;
    std::string error;
    cloth_sim::ClothState message = gridState(2, 2);
    message.positions[3].y = bad;
    EXPECT_FALSE(cloth_sim::fromStateMessage(message, 512, &positions_m, &error)) << bad;
    EXPECT_EQ(error, "position 3 is not finite or beyond 1e+06 m on an axis") << bad;
  }
  Eigen::Matrix3Xd positions_m;
  std::string error;
  cloth_sim::ClothState message = gridState(2, 2);
  message.positions[3].z = -cloth_sim::kMaxDrawnCoordinate_m;
  EXPECT_TRUE(cloth_sim::fromStateMessage(message, 512, &positions_m, &error)) << error;
}

TEST(FromStateMessage, GivesTheParticlesThatAreClothAndRefusesMalformedFlags) {
  Eigen::Matrix3Xd positions_m;
  std::vector<std::uint8_t> active{9};
  std::string error;
  cloth_sim::ClothState message = gridState(2, 2);
  ASSERT_TRUE(cloth_sim::fromStateMessage(message, 512, &positions_m, &active, &error)) << error;
  EXPECT_TRUE(active.empty()) << "no flags: every particle is cloth";
  message.active = {1, 0, 1, 1};
  ASSERT_TRUE(cloth_sim::fromStateMessage(message, 512, &positions_m, &active, &error)) << error;
  EXPECT_EQ(active, message.active);
  message.active = {1, 0, 1};
  EXPECT_FALSE(cloth_sim::fromStateMessage(message, 512, &positions_m, &active, &error));
  EXPECT_EQ(error, "3 active flags for 4 particles");
  message.active = {1, 0, 2, 1};
  EXPECT_FALSE(cloth_sim::fromStateMessage(message, 512, &positions_m, &active, &error));
  EXPECT_EQ(error, "active[2] = 2: must be 0 or 1");
}

// ---- GraspCommandQueue (issue 18): the last command of each id survives any flood ------------------

cloth_sim::Grasp::ConstPtr graspCommand(std::uint32_t id, std::uint8_t action, double x = 0.0) {
  auto command = boost::make_shared<cloth_sim::Grasp>();
  command->id = id;
  command->action = action;
  command->target.x = x;
  return command;
}

TEST(GraspCommandQueue, AFloodKeepsTheLastCommandOfEachIdInTheOrderOfTheirLastArrival) {
  cloth_sim::GraspCommandQueue queue;
  EXPECT_TRUE(queue.push(graspCommand(1, cloth_sim::Grasp::GRAB))) << "the first one asks for a drain";
  EXPECT_FALSE(queue.push(graspCommand(2, cloth_sim::Grasp::GRAB)));
  // 1000 rounds of GRAB and RELEASE of 16 ids, ending in RELEASE: a queue of 10 kept the last 10 only.
  for (int round = 0; round < 1000; ++round) {
    for (const std::uint8_t action : {cloth_sim::Grasp::GRAB, cloth_sim::Grasp::RELEASE}) {
      for (std::uint32_t id = 0; id < 16; ++id) queue.push(graspCommand(id, action, round));
    }
  }
  const std::vector<cloth_sim::Grasp::ConstPtr> pending = queue.take();
  ASSERT_EQ(pending.size(), 16u);
  for (std::uint32_t id = 0; id < 16; ++id) {
    EXPECT_EQ(pending[id]->id, id);
    EXPECT_EQ(pending[id]->action, cloth_sim::Grasp::RELEASE) << "id " << id;
  }
  EXPECT_TRUE(queue.take().empty());
  EXPECT_EQ(queue.takeDropped(), 0u);
  // A hand dragged at 900 Hz: only its latest target is applied.
  for (int k = 0; k < 100; ++k) queue.push(graspCommand(5, cloth_sim::Grasp::GRAB, k));
  const std::vector<cloth_sim::Grasp::ConstPtr> dragged = queue.take();
  ASSERT_EQ(dragged.size(), 1u);
  EXPECT_EQ(dragged.front()->target.x, 99.0);
}

TEST(GraspCommandQueue, AGrabAfterAPendingReleaseOfItsIdIsKeptBesideIt) {
  // An audit's, through the mouse: a new drag released the id's grasp and grabbed the clicked particle, the
  // GRAB replaced the pending RELEASE, and the GRAB alone dragged the particle the id held before.
  cloth_sim::GraspCommandQueue queue;
  queue.push(graspCommand(7, cloth_sim::Grasp::RELEASE));
  queue.push(graspCommand(7, cloth_sim::Grasp::GRAB, 1.0));
  queue.push(graspCommand(7, cloth_sim::Grasp::GRAB, 2.0));  // the new grasp dragged: it replaces the GRAB only
  std::vector<cloth_sim::Grasp::ConstPtr> pending = queue.take();
  ASSERT_EQ(pending.size(), 2u);
  EXPECT_EQ(pending[0]->action, cloth_sim::Grasp::RELEASE);
  EXPECT_EQ(pending[1]->action, cloth_sim::Grasp::GRAB);
  EXPECT_EQ(pending[1]->target.x, 2.0);
  // A later RELEASE ends both.
  queue.push(graspCommand(7, cloth_sim::Grasp::RELEASE));
  queue.push(graspCommand(7, cloth_sim::Grasp::GRAB));
  queue.push(graspCommand(7, cloth_sim::Grasp::RELEASE));
  pending = queue.take();
  ASSERT_EQ(pending.size(), 1u);
  EXPECT_EQ(pending[0]->action, cloth_sim::Grasp::RELEASE);
}

TEST(GraspCommandQueue, PastItsIdLimitGrabsMakeRoomAndReleasesStay) {
  cloth_sim::GraspCommandQueue queue;
  queue.push(graspCommand(0, cloth_sim::Grasp::RELEASE));
  for (std::uint32_t id = 1; id <= cloth_sim::GraspCommandQueue::kMaxPendingIds; ++id) {
    queue.push(graspCommand(id, cloth_sim::Grasp::GRAB));
  }
  EXPECT_EQ(queue.takeDropped(), 1u);
  const std::vector<cloth_sim::Grasp::ConstPtr> pending = queue.take();
  ASSERT_EQ(pending.size(), cloth_sim::GraspCommandQueue::kMaxPendingIds);
  EXPECT_EQ(pending.front()->id, 0u) << "the RELEASE stayed; the oldest GRAB (id 1) made room";
  EXPECT_EQ(pending[1]->id, 2u);
}

TEST(GraspCommandQueue, FullOfReleasesANewGrabGivesWayAndOnlyANewReleaseDisplacesOne) {
  cloth_sim::GraspCommandQueue queue;
  const std::size_t full = cloth_sim::GraspCommandQueue::kMaxPendingIds;
  for (std::uint32_t id = 0; id < full; ++id) queue.push(graspCommand(id, cloth_sim::Grasp::RELEASE));
  queue.push(graspCommand(5000, cloth_sim::Grasp::GRAB));
  EXPECT_EQ(queue.takeDropped(), 1u);
  std::vector<cloth_sim::Grasp::ConstPtr> pending = queue.take();
  ASSERT_EQ(pending.size(), full);
  for (std::uint32_t id = 0; id < full; ++id) {
    EXPECT_EQ(pending[id]->id, id) << "every RELEASE stayed; the new GRAB was dropped";
    EXPECT_EQ(pending[id]->action, cloth_sim::Grasp::RELEASE);
  }
  for (std::uint32_t id = 0; id < full; ++id) queue.push(graspCommand(id, cloth_sim::Grasp::RELEASE));
  queue.push(graspCommand(5000, cloth_sim::Grasp::RELEASE));
  EXPECT_EQ(queue.takeDropped(), 1u);
  pending = queue.take();
  ASSERT_EQ(pending.size(), full);
  EXPECT_EQ(pending.front()->id, 1u) << "a RELEASE can only be displaced by another: the oldest gave way";
  EXPECT_EQ(pending.back()->id, 5000u);
}

}  // namespace

TEST(ParticleCloud, ParticlesOutsideTheOutlineAreInvalidPoints) {
  // Issue 17: an organised cloud keeps the grid's shape; a removed particle is NaN and the cloud not dense.
  cloth_sim::core::SceneOptions options;
  options.rows = 9;
  options.cols = 9;
  options.pins.clear();
  options.outline.shape = cloth_sim::core::OutlineOptions::Shape::kCircle;
  options.outline.center_m = Eigen::Vector2d(0.5, 0.5);
  options.outline.radius_m = 0.5;
  const cloth_sim::core::Simulation simulation(options);
  const sensor_msgs::PointCloud2 cloud = cloth_sim::toParticleCloud(simulation, "world", ros::Time(1.0));
  EXPECT_FALSE(cloud.is_dense);
  ASSERT_EQ(cloud.width * cloud.height, 81u);
  int invalid = 0;
  for (int i = 0; i < 81; ++i) {
    float x = 0.0f;
    std::memcpy(&x, &cloud.data[static_cast<std::size_t>(i) * cloud.point_step], sizeof(float));
    EXPECT_EQ(std::isnan(x), !simulation.grid().isActive(i)) << i;
    invalid += std::isnan(x) ? 1 : 0;
  }
  EXPECT_GT(invalid, 0);
  EXPECT_LT(invalid, 81);
}

// ros::Time minus ros::Time throws std::runtime_error beyond +-2^31 s (a ros::Duration's seconds are an
// int32), and the node died of it under a /clock past 2^31 s (sim_time_late.test). secondsBetween gives
// every difference of two ros::Times, and where a Duration holds it, the same bits as the Duration.
TEST(SecondsBetween, IsTheDurationsSecondsWhereOneHoldsThemAndDoesNotThrowBeyond) {
  const std::vector<ros::Time> times{ros::Time(0, 0),          ros::Time(0, 1),           ros::Time(100, 20000000),
                                     ros::Time(100, 999999999), ros::Time(2147483647u, 5), ros::Time(2147483648u, 0),
                                     ros::Time(2147484748u, 0), ros::Time(4294967295u, 999999999)};
  int beyond = 0;
  for (const ros::Time& a : times) {
    for (const ros::Time& b : times) {
      const double seconds = cloth_sim::secondsBetween(a, b);
      const long double exact_s =
          (static_cast<long double>(b.toNSec()) - static_cast<long double>(a.toNSec())) * 1e-9L;
      double duration_s = 0.0;
      try {
        duration_s = (b - a).toSec();
      } catch (const std::runtime_error&) {
        ++beyond;
        EXPECT_NEAR(seconds, static_cast<double>(exact_s), 1e-6) << a << " to " << b;
        continue;
      }
      EXPECT_EQ(seconds, duration_s) << a << " to " << b;
    }
  }
  EXPECT_GT(beyond, 0) << "no pair beyond a ros::Duration's range: the test proves nothing there";
  EXPECT_EQ(cloth_sim::secondsBetween(ros::Time(100, 0), ros::Time(2147483748u, 0)), 2147483648.0);
  EXPECT_EQ(cloth_sim::secondsBetween(ros::Time(2147483748u, 0), ros::Time(100, 0)), -2147483648.0);
  EXPECT_EQ(cloth_sim::secondsBetween(ros::Time(0, 0), ros::Time(4294967295u, 999999999)), 4294967295.999999999);
  EXPECT_EQ(cloth_sim::secondsBetween(ros::Time(100, 999999999), ros::Time(100, 20000000)), -0.979999999);
}

// rviz keeps every marker a display was sent: the first ~colliders array after a scene change begins with
// a DELETEALL (the old scene's shapes go), the others only add (a DELETEALL every tick would make rviz
// rebuild every shape), and a scene without colliders clears and adds nothing.
TEST(ColliderMarkers, ClearTheDisplayOnlyWhenAskedAndThenFirst) {
  cloth_sim::core::SceneOptions options;
  options.rows = 5;
  options.cols = 5;
  options.colliders.spheres.push_back(cloth_sim::core::SphereCollider{});
  options.colliders.spheres.back().center_m = Eigen::Vector3d(0.0, 0.5, 0.0);
  options.colliders.spheres.back().radius_m = 0.1;
  const cloth_sim::core::Simulation simulation(options);
  const auto cleared = cloth_sim::toColliderMarkers(simulation, "world", ros::Time(1.0), true);
  ASSERT_EQ(cleared.markers.size(), 2u);
  EXPECT_EQ(cleared.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_EQ(cleared.markers[1].action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(cleared.markers[1].ns, "spheres");
  const auto added = cloth_sim::toColliderMarkers(simulation, "world", ros::Time(1.0), false);
  ASSERT_EQ(added.markers.size(), 1u);
  EXPECT_EQ(added.markers[0].action, visualization_msgs::Marker::ADD);
  options.colliders.spheres.clear();
  const cloth_sim::core::Simulation bare(options);
  const auto only_clear = cloth_sim::toColliderMarkers(bare, "world", ros::Time(1.0), true);
  ASSERT_EQ(only_clear.markers.size(), 1u);
  EXPECT_EQ(only_clear.markers[0].action, visualization_msgs::Marker::DELETEALL);
  EXPECT_TRUE(cloth_sim::toColliderMarkers(bare, "world", ros::Time(1.0), false).markers.empty());
}

// A recording or a viewer must know which particles an outline removed: ~state says so, and a viewer's
// mesh from the state is the node's own (reviewed 2026-11-27: both drew the removed particles, frozen
// where they started, joined to the cloth by stretched triangles).
TEST(StateMessage, SaysWhichParticlesAreClothAndTheMeshFromItIsTheNodes) {
  cloth_sim::core::SceneOptions options;
  options.rows = 9;
  options.cols = 9;
  options.pins.clear();
  cloth_sim::core::Simulation plain(options);
  EXPECT_TRUE(cloth_sim::toStateMessage(plain, "world", ros::Time(1.0)).active.empty());

  options.outline.shape = cloth_sim::core::OutlineOptions::Shape::kCircle;
  options.outline.center_m = Eigen::Vector2d(0.5, 0.5);
  options.outline.radius_m = 0.5;
  cloth_sim::core::Simulation simulation(options);
  for (int frame = 0; frame < 5; ++frame) simulation.advanceFrame();
  const cloth_sim::ClothState state = cloth_sim::toStateMessage(simulation, "world", ros::Time(1.0));
  ASSERT_EQ(state.active, simulation.grid().active);
  ASSERT_GT(std::count(state.active.begin(), state.active.end(), 0), 0);

  Eigen::Matrix3Xd positions_m;
  std::vector<std::uint8_t> active;
  std::string error;
  ASSERT_TRUE(cloth_sim::fromStateMessage(state, 512, &positions_m, &active, &error)) << error;
  const cloth_sim::core::ClothGrid grid =
      cloth_sim::core::buildClothGrid(9, 9, 1.0, 1.0, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                      Eigen::Vector3d::UnitY(), active);
  const Eigen::Matrix3Xf colors = Eigen::Matrix3Xf::Ones(3, positions_m.cols());
  const visualization_msgs::Marker drawn = cloth_sim::toMeshMarker(grid, positions_m, colors, "world", ros::Time(1.0));
  const visualization_msgs::Marker node = cloth_sim::toMeshMarker(simulation, "world", ros::Time(1.0));
  ASSERT_EQ(drawn.points.size(), node.points.size());
  EXPECT_LT(drawn.points.size(), 6u * 8u * 8u);
  for (std::size_t k = 0; k < drawn.points.size(); ++k) {
    EXPECT_EQ(drawn.points[k].x, node.points[k].x) << k;
    EXPECT_EQ(drawn.points[k].y, node.points[k].y) << k;
    EXPECT_EQ(drawn.points[k].z, node.points[k].z) << k;
  }
}
