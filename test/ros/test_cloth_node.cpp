// rostest client for cloth_node. Each test/ros/*.test starts the node in one configuration and runs
// this client with a --gtest_filter for the suites that configuration proves:
//   mesh_rate.test    Mesh.*                                   (two 8x8 nodes, one with a custom frame_id)
//   interaction.test  Wind.*:BadInput.*:Grasp.*                (hanging scene, wall time)
//   bad_messages.test NodeTest.BadMessage*                     (every kind of bad ~wind and ~grasp)
//   services.test     Services.*:LoadScene.*:Reconfigure.*:Diagnostics.*
//   load_scene_refusals.test LoadSceneRefusal.*               (bad ~load_scene requests, old scene runs)
//   ball.test         Ball.*                                   (config/scenes/ball.yaml)
//   sim_time.test     SimTime.*                                (/use_sim_time, the test drives /clock)
//   sim_time_twins.test SimTimeTwins.*                       (two node processes on one /clock)
//   sim_time_rewind.test SimTimeRewind.*                     (/clock sent back after leaps, a fresh node)
//   sim_time_tf.test  SimTimeTf.*                              (ball under /use_sim_time: its spheres' tf, colliders)
//   sim_time_late.test SimTimeLate.*                         (/clock past 2^31 s, leaps, ~attach ages)
//   bad_params.test   BadParams.*                              (no node: the tests start it themselves)
// Every wait is a condition with a wall-clock deadline; no test sleeps to "let things settle".
#include "test_helpers.h"

#include <cloth_sim/Attach.h>
#include <cloth_sim/ClothState.h>
#include <cloth_sim/Grasp.h>
#include <cloth_sim/LoadScene.h>
#include <cloth_sim/LoadState.h>
#include <cloth_sim/SaveState.h>
#include <cloth_sim/Step.h>
#include <diagnostic_msgs/DiagnosticArray.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <ros/package.h>
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <gtest/gtest.h>
#include <unistd.h>

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

using cloth_sim::ClothState;
using namespace cloth_sim_test;

namespace {

/// One frame at the node's 50 Hz.
constexpr double kFrame_s = 0.02;
/// The hanging scene's grid (config/scenes/hanging.yaml).
constexpr std::uint32_t kHangingRows = 20;
constexpr std::uint32_t kHangingCols = 20;
/// How far the mean y of the cloth must move before we call it "pushed": 5 cm. Without wind the hanging
/// cloth stays exactly in the y = 0 plane, and a 5 m/s wind swings it by tens of cm.
constexpr double kPushed_m = 0.05;

std::string privateParam(const std::string& name, const std::string& fallback) {
  std::string value;
  ros::NodeHandle("~").param<std::string>(name, value, fallback);
  return value;
}

/// The node under test (~node, default /cloth_node).
std::string nodeName() { return privateParam("node", "/cloth_node"); }
std::string nodeTopic(const std::string& name) { return nodeName() + "/" + name; }

double meanY(const ClothState& state) {
  double sum = 0.0;
  for (const auto& p : state.positions) sum += p.y;
  return state.positions.empty() ? 0.0 : sum / state.positions.size();
}

bool finite(const geometry_msgs::Point& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

bool allFinite(const ClothState& state) {
  for (const auto& p : state.positions) {
    if (!finite(p)) return false;
  }
  for (const auto& v : state.velocities) {
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
  }
  return true;
}

double distance(const geometry_msgs::Point& a, const geometry_msgs::Point& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

/// A ~grasp GRAB of `particle` towards `target` (world frame) with a spring of `stiffness` N/m.
cloth_sim::Grasp grabMessage(std::uint32_t id, int particle, const geometry_msgs::Point& target, double stiffness) {
  cloth_sim::Grasp grab;
  grab.header.frame_id = "world";
  grab.id = id;
  grab.action = cloth_sim::Grasp::GRAB;
  grab.particle = particle;
  grab.target = target;
  grab.stiffness = stiffness;
  return grab;
}

/// Bit-for-bit comparison of positions and velocities; reports the first difference.
::testing::AssertionResult sameBits(const ClothState& a, const ClothState& b) {
  if (a.positions.size() != b.positions.size() || a.velocities.size() != b.velocities.size()) {
    return ::testing::AssertionFailure() << "sizes differ: " << a.positions.size() << " vs " << b.positions.size();
  }
  for (std::size_t i = 0; i < a.positions.size(); ++i) {
    const auto& p = a.positions[i];
    const auto& q = b.positions[i];
    if (p.x != q.x || p.y != q.y || p.z != q.z) {
      return ::testing::AssertionFailure() << "position " << i << " differs: (" << p.x << ", " << p.y << ", " << p.z
                                           << ") vs (" << q.x << ", " << q.y << ", " << q.z << ")";
    }
    const auto& u = a.velocities[i];
    const auto& w = b.velocities[i];
    if (u.x != w.x || u.y != w.y || u.z != w.z) {
      return ::testing::AssertionFailure() << "velocity " << i << " differs";
    }
  }
  return ::testing::AssertionSuccess();
}

/// Checks one node's mesh marker: a TRIANGLE_LIST of 6 (rows-1)(cols-1) finite points with as many
/// colours in [0, 1], in the expected frame.
void checkMesh(const std::string& node, const std::string& frame_id, std::uint32_t rows, std::uint32_t cols) {
  SCOPED_TRACE("node " + node);
  ros::NodeHandle nh;
  Monitor<visualization_msgs::Marker> meshes(nh, node + "/mesh");
  Monitor<ClothState> states(nh, node + "/state");
  const auto mesh = meshes.waitForNext(15.0, 0);
  ASSERT_TRUE(mesh) << "no marker on " << node << "/mesh";
  const auto state = states.waitForNext(15.0, 0);
  ASSERT_TRUE(state) << "no state on " << node << "/state";
  EXPECT_EQ(state->rows, rows);
  EXPECT_EQ(state->cols, cols);
  EXPECT_EQ(state->header.frame_id, frame_id);

  EXPECT_EQ(mesh->type, visualization_msgs::Marker::TRIANGLE_LIST);
  EXPECT_EQ(mesh->action, visualization_msgs::Marker::ADD);
  EXPECT_EQ(mesh->header.frame_id, frame_id);
  const std::size_t expected_points = 6u * (rows - 1) * (cols - 1);
  EXPECT_EQ(mesh->points.size(), expected_points);
  EXPECT_EQ(mesh->colors.size(), expected_points);
  std::size_t bad_points = 0;
  for (const auto& p : mesh->points) bad_points += finite(p) ? 0 : 1;
  EXPECT_EQ(bad_points, 0u) << "non-finite mesh points";
  std::size_t bad_colors = 0;
  for (const auto& c : mesh->colors) {
    const bool ok = std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b) && std::isfinite(c.a) &&
                    c.r >= 0 && c.r <= 1 && c.g >= 0 && c.g <= 1 && c.b >= 0 && c.b <= 1 && c.a > 0;
    bad_colors += ok ? 0 : 1;
  }
  EXPECT_EQ(bad_colors, 0u) << "colours outside [0, 1] or transparent";
  EXPECT_TRUE(allFinite(*state));
}

}  // namespace

// ---- 1. Mesh content (mesh_rate.test; the rate itself is the hztest there) ------------------------

TEST(LaunchArgs, RowsColsIntegratorAndSubstepsReachTheNode) {
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  const ClothState::ConstPtr state = states.waitForNext(20.0, 0);
  ASSERT_TRUE(state) << "no ClothState on " << nodeTopic("state");
  ros::NodeHandle expected("~");
  EXPECT_EQ(state->rows, static_cast<std::uint32_t>(expected.param("rows", 0)));
  EXPECT_EQ(state->cols, static_cast<std::uint32_t>(expected.param("cols", 0)));
  EXPECT_EQ(state->integrator, expected.param<std::string>("integrator", ""));
  EXPECT_EQ(state->substeps, static_cast<std::uint32_t>(expected.param("substeps", 0)));
}

TEST(LaunchArgs, TheFrameIdIsInTfUnderItsParent) {
  // cloth.launch's parent_frame (map): rviz, whose fixed frame is frame_id, finds it in every scene.
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  std::string why;
  EXPECT_TRUE(buffer.canTransform("map", "world", ros::Time(0), ros::Duration(10.0), &why)) << why;
}

TEST(Mesh, TriangleListOfFiniteColouredPointsInFrameId) {
  ros::NodeHandle pnh("~");
  int rows = 0;
  int cols = 0;
  pnh.param("rows", rows, 8);
  pnh.param("cols", cols, 8);
  checkMesh(nodeName(), "world", rows, cols);
}

TEST(Mesh, CustomFrameIdIsUsed) {
  int rows = 0;
  int cols = 0;
  ros::NodeHandle pnh("~");
  pnh.param("rows", rows, 8);
  pnh.param("cols", cols, 8);
  checkMesh(privateParam("framed_node", "/cloth_node_framed"), privateParam("framed_frame", "cloth_frame"), rows,
            cols);
}

// ---- Fixture for one long-running node in wall time --------------------------------------------

class NodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    states_ = std::make_unique<Monitor<ClothState>>(nh_, nodeTopic("state"));
    log_ = std::make_unique<Monitor<rosgraph_msgs::Log>>(nh_, "/rosout", 1000);
    ASSERT_TRUE(states_->waitForNext(15.0, 0)) << "no ClothState on " << nodeTopic("state");
  }

  /// A fresh hanging scene: load_scene builds a new simulation, so wind, grasps and tuning from earlier
  /// tests are gone. Paused or running as asked; when paused, *frame0 receives the frame-0 state.
  void freshScene(bool paused, ClothState::ConstPtr* frame0 = nullptr) {
    ASSERT_NO_FATAL_FAILURE(setPaused(true));
    cloth_sim::LoadScene load;
    load.request.scene = "hanging";
    const std::uint64_t since = states_->count();
    ASSERT_TRUE(callService(nodeTopic("load_scene"), load));
    ASSERT_TRUE(load.response.success) << load.response.message;
    std::uint64_t index = 0;
    const auto first = states_->waitFor([](const ClothState& s) { return s.frame == 0; }, 10.0, since, &index);
    ASSERT_TRUE(first) << "no frame-0 state after load_scene";
    ASSERT_EQ(first->rows, kHangingRows);
    ASSERT_EQ(first->cols, kHangingCols);
    if (frame0) *frame0 = first;
    if (!paused) {
      ASSERT_NO_FATAL_FAILURE(setPaused(false));
    }
  }

  void setPaused(bool paused) {
    std_srvs::SetBool pause;
    pause.request.data = paused;
    ASSERT_TRUE(callService(nodeTopic("pause"), pause));
    ASSERT_TRUE(pause.response.success) << pause.response.message;
  }

  /// While paused: steps `frames` and returns the state the step published (sim_time as answered).
  ClothState::ConstPtr step(std::uint32_t frames, cloth_sim::Step::Response* answer = nullptr) {
    cloth_sim::Step step;
    step.request.frames = frames;
    const std::uint64_t since = states_->count();
    if (!callService(nodeTopic("step"), step)) return nullptr;
    if (answer) *answer = step.response;
    if (!step.response.success) {
      ADD_FAILURE() << "step " << frames << " refused: " << step.response.message;
      return nullptr;
    }
    const double sim_time = step.response.sim_time;
    auto state = states_->waitFor([&](const ClothState& s) { return s.sim_time == sim_time; }, 10.0, since);
    if (!state) ADD_FAILURE() << "no state with sim_time " << sim_time << " after the step";
    return state;
  }

  /// While paused: reset, and the frame-0 state it published.
  ClothState::ConstPtr reset() {
    std_srvs::Trigger trigger;
    const std::uint64_t since = states_->count();
    if (!callService(nodeTopic("reset"), trigger)) return nullptr;
    EXPECT_TRUE(trigger.response.success) << trigger.response.message;
    return states_->waitFor([](const ClothState& s) { return s.frame == 0; }, 10.0, since);
  }

  /// A log line from the node containing `text`, received after `since`.
  rosgraph_msgs::Log::ConstPtr waitForLog(const std::string& text, double timeout_s, std::uint64_t since = 0) {
    const std::string node = nodeName();
    return log_->waitFor(
        [&](const rosgraph_msgs::Log& m) { return m.name == node && m.msg.find(text) != std::string::npos; },
        timeout_s, since);
  }

  ros::NodeHandle nh_;
  std::unique_ptr<Monitor<ClothState>> states_;
  std::unique_ptr<Monitor<rosgraph_msgs::Log>> log_;
};

// ---- 2. Wind (interaction.test) -------------------------------------------------------------------

class Wind : public NodeTest {
 protected:
  /// Publishes `wind` (again every 0.25 s: a wind in a frame the node cannot resolve yet is dropped)
  /// until the cloth's mean y exceeds its value at the start by kPushed_m.
  void expectPushedAlongY(const geometry_msgs::Vector3Stamped& wind) {
    ros::Publisher publisher = nh_.advertise<geometry_msgs::Vector3Stamped>(nodeTopic("wind"), 10);
    ASSERT_TRUE(waitForSubscribers(publisher, 1, 10.0)) << "the node does not subscribe to ~wind";
    const std::uint64_t since = states_->count();
    const auto start = states_->waitForNext(5.0, since);
    ASSERT_TRUE(start);
    const double y0 = meanY(*start);
    ClothState::ConstPtr pushed;
    const auto deadline = deadlineIn(15.0);
    while (!pushed && Clock::now() < deadline) {
      publisher.publish(wind);
      pushed = states_->waitFor([&](const ClothState& s) { return meanY(s) > y0 + kPushed_m; }, 0.25, since);
    }
    ASSERT_TRUE(pushed) << "mean y stayed near " << y0 << " m (last " << meanY(*states_->latest()) << " m)";
    EXPECT_TRUE(allFinite(*pushed));
  }
};

TEST_F(Wind, PushesTheClothDownwind) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  geometry_msgs::Vector3Stamped wind;
  wind.header.frame_id = "world";
  wind.vector.y = 5.0;
  expectPushedAlongY(wind);
}

namespace {

/// Puts `child` in tf as world turned +90 degrees about z (its x axis along world's y), static; the
/// broadcaster must outlive the test's use of the frame.
void sendQuarterTurnAboutZ(tf2_ros::StaticTransformBroadcaster& broadcaster, const std::string& child) {
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time::now();
  transform.header.frame_id = "world";
  transform.child_frame_id = child;
  transform.transform.rotation.z = std::sin(M_PI / 4.0);
  transform.transform.rotation.w = std::cos(M_PI / 4.0);
  broadcaster.sendTransform(transform);
}

}  // namespace

TEST_F(Wind, WindInAnotherFrameIsRotatedIntoFrameId) {
  // wind_frame is world turned +90 deg about z: its x axis is world's y. A 5 m/s wind along wind_frame's
  // x must push the cloth along world +y; unrotated it would blow along the cloth's plane (no push),
  // rotated the wrong way it would push towards -y.
  tf2_ros::StaticTransformBroadcaster broadcaster;
  sendQuarterTurnAboutZ(broadcaster, "wind_frame");

  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  geometry_msgs::Vector3Stamped wind;
  wind.header.frame_id = "wind_frame";
  wind.vector.x = 5.0;
  expectPushedAlongY(wind);
}

// ---- 3. Bad input is dropped (interaction.test) ---------------------------------------------------

TEST_F(NodeTest, BadInputIsDroppedAndTheClothUntouched) {
  Monitor<visualization_msgs::Marker> meshes(nh_, nodeTopic("mesh"));
  constexpr std::uint32_t kFrames = 10;
  // Reference: kFrames paused steps from frame 0 with no input at all.
  ASSERT_NO_FATAL_FAILURE(freshScene(true));
  // load_scene logs at INFO: once that line arrives, our /rosout subscription is connected to the node.
  ASSERT_TRUE(waitForLog("loaded scene", 10.0)) << "no INFO from the node on /rosout";
  const auto reference = step(kFrames);
  ASSERT_TRUE(reference);
  ASSERT_EQ(reference->frame, kFrames);

  ASSERT_TRUE(reset());
  ros::Publisher wind_pub = nh_.advertise<geometry_msgs::Vector3Stamped>(nodeTopic("wind"), 10);
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 10);
  ASSERT_TRUE(waitForSubscribers(wind_pub, 1, 10.0));
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  const std::uint64_t log_since = log_->count();
  geometry_msgs::Vector3Stamped nan_wind;
  nan_wind.header.frame_id = "world";
  nan_wind.vector.x = std::numeric_limits<double>::quiet_NaN();
  nan_wind.vector.y = 1.0;
  wind_pub.publish(nan_wind);
  cloth_sim::Grasp grasp;
  grasp.header.frame_id = "world";
  grasp.id = 7;
  grasp.action = cloth_sim::Grasp::GRAB;
  grasp.particle = 1000000000;
  grasp.target.z = 1.0;
  grasp_pub.publish(grasp);
  // The node says it dropped them: only then do we know it has handled them before the steps below.
  EXPECT_TRUE(waitForLog("dropped ~wind", 10.0, log_since)) << "no warning about the NaN wind";
  EXPECT_TRUE(waitForLog("dropped ~grasp", 10.0, log_since)) << "no warning about particle 1000000000";

  const auto after = step(kFrames);
  ASSERT_TRUE(after);
  EXPECT_EQ(after->frame, kFrames);
  EXPECT_TRUE(allFinite(*after));
  EXPECT_TRUE(sameBits(*reference, *after)) << "the dropped input changed the cloth";

  // Alive: it keeps publishing, and the mesh it publishes is finite.
  const auto mesh = meshes.waitForNext(10.0, meshes.count());
  ASSERT_TRUE(mesh) << "the node stopped publishing its mesh";
  for (const auto& p : mesh->points) ASSERT_TRUE(finite(p));
  EXPECT_TRUE(states_->waitForNext(10.0, states_->count())) << "the node stopped publishing its state";
}

// ---- 4. Grasp (interaction.test) ------------------------------------------------------------------

TEST_F(NodeTest, GraspReachesTargetAndReleaseLetsItFall) {
  ClothState::ConstPtr frame0;
  ASSERT_NO_FATAL_FAILURE(freshScene(false, &frame0));
  const int particle = static_cast<int>((kHangingRows - 1) * kHangingCols);  // bottom-left corner, free
  // Lift the corner 0.3 m up and 0.3 m out of the cloth's plane.
  geometry_msgs::Point target = frame0->positions[particle];
  target.y += 0.3;
  target.z += 0.3;
  // Tolerance: the grasp spring (500 N/m) can at most carry the whole cloth's weight (0.5 kg * 9.81 =
  // 4.9 N), a static error of <= 1 cm; 2 cm leaves room for the residual swing.
  constexpr double kStiffness_N_per_m = 500.0;
  constexpr double kTolerance_m = 0.02;
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 10);
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  const cloth_sim::Grasp grab = grabMessage(1, particle, target, kStiffness_N_per_m);
  const std::uint64_t since = states_->count();
  grasp_pub.publish(grab);
  const auto reached = states_->waitFor(
      [&](const ClothState& s) { return distance(s.positions[particle], target) < kTolerance_m; }, 20.0, since);
  ASSERT_TRUE(reached) << "particle " << particle << " ended "
                       << distance(states_->latest()->positions[particle], target) << " m from its target";
  EXPECT_TRUE(allFinite(*reached));

  cloth_sim::Grasp release;
  release.id = 1;
  release.action = cloth_sim::Grasp::RELEASE;
  const std::uint64_t release_since = states_->count();
  const double z_held = states_->latest()->positions[particle].z;
  grasp_pub.publish(release);
  const auto fallen = states_->waitFor(
      [&](const ClothState& s) { return s.positions[particle].z < z_held - 0.1; }, 10.0, release_since);
  EXPECT_TRUE(fallen) << "released particle stayed at z = " << states_->latest()->positions[particle].z
                      << " m (held at " << z_held << " m)";
}

// A review's: a grab's target was expressed from header.frame_id into the node's frame, its force was
// taken as given, in the node's frame whatever the header said.
TEST_F(NodeTest, GraspForceInAnotherFrameIsRotatedIntoFrameId) {
  // grasp_frame is world turned +90 deg about z: its x axis is world's y. A 5 N force along grasp_frame's x
  // must push the held corner along world +y, out of the hanging cloth's plane (y = 0); unrotated it would
  // push along world x, in the plane (y stays 0), and rotated the wrong way towards -y.
  tf2_ros::StaticTransformBroadcaster broadcaster;
  sendQuarterTurnAboutZ(broadcaster, "grasp_frame");

  ClothState::ConstPtr frame0;
  ASSERT_NO_FATAL_FAILURE(freshScene(false, &frame0));
  const int particle = static_cast<int>((kHangingRows - 1) * kHangingCols);  // bottom-left corner, free
  // Held where it hangs (that point in grasp_frame: world (x, y, z) is (y, -x, z) there) by a 100 N/m
  // spring: the force moves it about 5 N / 100 N/m = 5 cm; half of that is the test's bar.
  const geometry_msgs::Point& rest = frame0->positions[particle];
  cloth_sim::Grasp grab = grabMessage(1, particle, geometry_msgs::Point(), 100.0);
  grab.header.frame_id = "grasp_frame";
  grab.target.x = rest.y;
  grab.target.y = -rest.x;
  grab.target.z = rest.z;
  grab.force.x = 5.0;
  constexpr double kPushed_m = 0.025;
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 10);
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  const std::uint64_t since = states_->count();
  ClothState::ConstPtr pushed;
  const auto deadline = deadlineIn(15.0);
  while (!pushed && Clock::now() < deadline) {
    grasp_pub.publish(grab);  // again until it acts: a grab in a frame tf does not know yet is dropped
    pushed = states_->waitFor([&](const ClothState& s) { return s.positions[particle].y > rest.y + kPushed_m; },
                              0.25, since);
  }
  const geometry_msgs::Point& last = states_->latest()->positions[particle];
  ASSERT_TRUE(pushed) << "particle " << particle << " went from (" << rest.x << ", " << rest.y << ", " << rest.z
                      << ") to (" << last.x << ", " << last.y << ", " << last.z << ")";
  EXPECT_TRUE(allFinite(*pushed));
  cloth_sim::Grasp release;
  release.id = 1;
  release.action = cloth_sim::Grasp::RELEASE;
  grasp_pub.publish(release);
}

// ---- 3b. Every kind of bad message (bad_messages.test: a node of its own, so that no earlier test has
// used the throttled warnings these wait for; in this order) -------------------------------------------

TEST_F(NodeTest, BadMessageSeventeenthGraspIsDropped) {
  ClothState::ConstPtr frame0;
  ASSERT_NO_FATAL_FAILURE(freshScene(true, &frame0));
  ASSERT_TRUE(waitForLog("loaded scene", 10.0)) << "no INFO from the node on /rosout";
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 100);
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  ASSERT_NO_FATAL_FAILURE(setPaused(false));
  const std::uint64_t log_since = log_->count();
  // Each hand lifts its particle (second row, free) 10 cm; the next is sent once it has risen 2 cm, so
  // all 16 are held (the node's ~grasp queue holds 10 messages: a burst of 17 would lose some).
  constexpr double kLift_m = 0.1;
  constexpr double kRisen_m = 0.02;
  constexpr std::uint32_t kGrasps = 17;  // Simulation::kMaxGrasps + 1
  for (std::uint32_t id = 1; id <= kGrasps; ++id) {
    cloth_sim::Grasp grab;
    grab.header.frame_id = "world";
    grab.id = id;
    grab.action = cloth_sim::Grasp::GRAB;
    grab.particle = static_cast<int>(kHangingCols + id);
    grab.target = frame0->positions[grab.particle];
    grab.target.z += kLift_m;
    grab.stiffness = 500.0;
    const std::uint64_t since = states_->count();
    grasp_pub.publish(grab);
    if (id == kGrasps) break;
    const double z0 = frame0->positions[grab.particle].z;
    ASSERT_TRUE(states_->waitFor([&](const ClothState& s) { return s.positions[grab.particle].z > z0 + kRisen_m; },
                                 10.0, since))
        << "grasp " << id << " did not lift its particle";
  }
  const auto warning = waitForLog("dropped ~grasp id 17", 10.0, log_since);
  ASSERT_TRUE(warning) << "no warning about the 17th grasp";
  EXPECT_NE(warning->msg.find("16"), std::string::npos) << warning->msg;
}

TEST_F(NodeTest, BadMessagesOfEveryKindLeaveTheClothUntouched) {
  constexpr std::uint32_t kFrames = 10;
  ASSERT_NO_FATAL_FAILURE(freshScene(true));
  ASSERT_TRUE(waitForLog("loaded scene", 10.0)) << "no INFO from the node on /rosout";
  const auto reference = step(kFrames);
  ASSERT_TRUE(reference);
  ASSERT_TRUE(reset());
  ros::Publisher wind_pub = nh_.advertise<geometry_msgs::Vector3Stamped>(nodeTopic("wind"), 100);
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 100);
  ASSERT_TRUE(waitForSubscribers(wind_pub, 1, 10.0));
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  const std::uint64_t log_since = log_->count();
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();

  // ~wind: infinite, 173 m/s (each component within 100), then in a frame tf does not know. One
  // subscription is served in order, so the last warning means the earlier ones were handled too
  // (warnings from one place are throttled to one per 5 s).
  const auto wind = [&](double x, double y, double z, const std::string& frame) {
    geometry_msgs::Vector3Stamped message;
    message.header.frame_id = frame;
    message.vector.x = x;
    message.vector.y = y;
    message.vector.z = z;
    wind_pub.publish(message);
  };
  wind(inf, 0.0, 0.0, "world");
  wind(100.0, 100.0, 100.0, "world");
  wind(nan, nan, nan, "world");
  wind(5.0, 0.0, 0.0, "no_such_frame");
  EXPECT_TRUE(waitForLog("dropped ~wind (inf", 10.0, log_since)) << "no warning about the infinite wind";
  EXPECT_TRUE(waitForLog("dropped ~wind in frame 'no_such_frame'", 10.0, log_since));

  // ~grasp: unknown release, unknown action, NaN target, infinite stiffness, NaN force, particles out of
  // range both ways, then a frame tf does not know.
  const auto grasp = [&](std::uint32_t id, std::uint8_t action, int particle, double target_z, double stiffness,
                         double force, const std::string& frame) {
    cloth_sim::Grasp message;
    message.header.frame_id = frame;
    message.id = id;
    message.action = action;
    message.particle = particle;
    message.target.z = target_z;
    message.stiffness = stiffness;
    message.force.x = force;
    grasp_pub.publish(message);
  };
  grasp(99, cloth_sim::Grasp::RELEASE, 0, 1.0, 0.0, 0.0, "world");
  grasp(21, 7, 0, 1.0, 0.0, 0.0, "world");
  grasp(22, cloth_sim::Grasp::GRAB, 5, nan, 0.0, 0.0, "world");
  grasp(23, cloth_sim::Grasp::GRAB, 5, 1.0, inf, 0.0, "world");
  grasp(24, cloth_sim::Grasp::GRAB, 5, 1.0, 0.0, nan, "world");
  grasp(25, cloth_sim::Grasp::GRAB, -2, 1.0, 0.0, 0.0, "world");
  grasp(26, cloth_sim::Grasp::GRAB, static_cast<int>(kHangingRows * kHangingCols), 1.0, 0.0, 0.0, "world");
  grasp(27, cloth_sim::Grasp::GRAB, 5, 1.0, 0.0, 0.0, "no_such_frame");
  EXPECT_TRUE(waitForLog("no grasp with id 99", 10.0, log_since));
  EXPECT_TRUE(waitForLog("action 7", 10.0, log_since));
  EXPECT_TRUE(waitForLog("dropped ~grasp id 22: target is not finite", 10.0, log_since));
  // Ids 23 to 26 share one warning with the 17th grasp of the test before (throttled); id 27 comes after
  // them on the same subscription, and the bits below show that none of them acted.
  EXPECT_TRUE(waitForLog("dropped ~grasp id 27 in frame 'no_such_frame'", 10.0, log_since));

  const auto after = step(kFrames);
  ASSERT_TRUE(after);
  EXPECT_TRUE(allFinite(*after));
  EXPECT_TRUE(sameBits(*reference, *after)) << "a dropped message changed the cloth";
}

// ---- 5. reset, pause and step (services.test) -----------------------------------------------------

TEST_F(NodeTest, ResetRestoresTheFirstFrame) {
  ClothState::ConstPtr frame0;
  ASSERT_NO_FATAL_FAILURE(freshScene(true, &frame0));
  ASSERT_NO_FATAL_FAILURE(setPaused(false));
  const auto later = states_->waitFor([](const ClothState& s) { return s.frame >= 25; }, 15.0, states_->count());
  ASSERT_TRUE(later) << "the running node did not reach frame 25";
  ASSERT_FALSE(sameBits(*frame0, *later)) << "the cloth did not move in 25 frames: the test would prove nothing";
  // A grasp the reset lets go is named in its answer: its client must grasp again.
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 10);
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  const int particle = static_cast<int>((kHangingRows - 1) * kHangingCols);  // bottom-left corner, free
  grasp_pub.publish(grabMessage(7, particle, frame0->positions[particle], 0.0));
  const std::uint64_t grabbed_since = states_->count();
  ASSERT_TRUE(states_->waitFor([](const ClothState&) { return true; }, 10.0, grabbed_since + 5));

  std_srvs::Trigger trigger;
  const std::uint64_t since = states_->count();
  ASSERT_TRUE(callService(nodeTopic("reset"), trigger));
  EXPECT_TRUE(trigger.response.success) << trigger.response.message;
  EXPECT_EQ(trigger.response.message, "scene 'hanging' back at frame 0; released grasp ids 7");
  const auto reset = states_->waitFor([](const ClothState& s) { return s.frame == 0; }, 10.0, since);
  ASSERT_TRUE(reset) << "no frame-0 state after reset";
  EXPECT_EQ(reset->frame, 0u);
  EXPECT_EQ(reset->sim_time, 0.0);
  EXPECT_TRUE(sameBits(*frame0, *reset));
  ASSERT_TRUE(callService(nodeTopic("reset"), trigger));
  EXPECT_EQ(trigger.response.message, "scene 'hanging' back at frame 0") << "no grasp was left to release";

  // Paused after a reset there is no last frame: the diagnostics read 0 substeps and iterations (README,
  // "Diagnostics"), not the frame before the reset's. Before, they kept the last frame's report.
  ASSERT_NO_FATAL_FAILURE(setPaused(false));
  ASSERT_TRUE(states_->waitFor([](const ClothState& s) { return s.frame >= 10; }, 15.0, states_->count()));
  ASSERT_NO_FATAL_FAILURE(setPaused(true));
  Monitor<diagnostic_msgs::DiagnosticArray> diagnostics(nh_, "/diagnostics");
  ASSERT_TRUE(callService(nodeTopic("reset"), trigger));
  const std::string name = nodeName().substr(1) + ": simulation";
  std::map<std::string, std::string> values;
  const auto at_frame_0 = [&](const diagnostic_msgs::DiagnosticArray& array) {
    for (const auto& status : array.status) {
      if (status.name != name) continue;
      values.clear();
      for (const auto& kv : status.values) values[kv.key] = kv.value;
      return values["frame"] == "0";
    }
    return false;
  };
  ASSERT_TRUE(diagnostics.waitFor(at_frame_0, 10.0, diagnostics.count())) << "no diagnostics at frame 0 after reset";
  EXPECT_EQ(values["substeps used"], "0");
  EXPECT_EQ(values["solver iterations per step"], "0");
  ASSERT_NO_FATAL_FAILURE(setPaused(false));
}

TEST_F(NodeTest, PausedStepAdvancesExactlyNFrames) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  ASSERT_TRUE(states_->waitFor([](const ClothState& s) { return s.frame >= 5; }, 15.0, states_->count()));
  ASSERT_NO_FATAL_FAILURE(setPaused(true));
  cloth_sim::Step::Response first_answer;
  const auto first = step(1, &first_answer);
  ASSERT_TRUE(first);
  constexpr std::uint32_t kFrames = 7;
  cloth_sim::Step::Response answer;
  const auto stepped = step(kFrames, &answer);
  ASSERT_TRUE(stepped);
  EXPECT_EQ(stepped->frame, first->frame + kFrames);
  // Frame times are computed from the frame start, so N frames add N * 0.02 s up to rounding (1e-9 s).
  EXPECT_NEAR(answer.sim_time - first_answer.sim_time, kFrames * kFrame_s, 1e-9);
  EXPECT_EQ(stepped->sim_time, answer.sim_time);

  // Paused: the node keeps publishing the very same state.
  const std::uint64_t since = states_->count();
  for (int k = 0; k < 5; ++k) {
    const auto next = states_->waitForNext(10.0, since + k);
    ASSERT_TRUE(next) << "the paused node stopped publishing";
    EXPECT_EQ(next->frame, stepped->frame);
    EXPECT_TRUE(sameBits(*stepped, *next));
  }
}

TEST_F(NodeTest, StepIsRefusedUnlessPaused) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  cloth_sim::Step step;
  step.request.frames = 1;
  ASSERT_TRUE(callService(nodeTopic("step"), step));
  EXPECT_FALSE(step.response.success);
  EXPECT_FALSE(step.response.message.empty());
  // And zero frames is refused even while paused.
  ASSERT_NO_FATAL_FAILURE(setPaused(true));
  cloth_sim::Step zero;
  zero.request.frames = 0;
  ASSERT_TRUE(callService(nodeTopic("step"), zero));
  EXPECT_FALSE(zero.response.success);
}

TEST_F(NodeTest, StepOfZeroFramesIsRefusedWithAReason) {
  ASSERT_NO_FATAL_FAILURE(freshScene(true));
  cloth_sim::Step zero;
  zero.request.frames = 0;
  const std::uint64_t frame_before = states_->waitForNext(10.0, states_->count())->frame;
  ASSERT_TRUE(callService(nodeTopic("step"), zero));
  EXPECT_FALSE(zero.response.success);
  EXPECT_NE(zero.response.message.find("frames"), std::string::npos) << zero.response.message;
  const auto after = states_->waitForNext(10.0, states_->count());
  ASSERT_TRUE(after) << "the node stopped publishing";
  EXPECT_EQ(after->frame, frame_before);
}

// ---- 6. load_scene (services.test) ----------------------------------------------------------------

TEST_F(NodeTest, LoadSceneOfAMissingSceneKeepsTheOldOne) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  cloth_sim::LoadScene load;
  load.request.scene = "no_such_scene";
  ASSERT_TRUE(callService(nodeTopic("load_scene"), load));
  EXPECT_FALSE(load.response.success);
  EXPECT_NE(load.response.message.find("no_such_scene"), std::string::npos) << load.response.message;
  // The old scene keeps running: 10 more frames, same grid.
  const std::uint64_t since = states_->count();
  const auto now = states_->waitForNext(10.0, since);
  ASSERT_TRUE(now);
  const auto later =
      states_->waitFor([&](const ClothState& s) { return s.frame >= now->frame + 10; }, 15.0, since);
  ASSERT_TRUE(later) << "the old scene stopped running";
  EXPECT_EQ(later->rows, kHangingRows);
  EXPECT_EQ(later->cols, kHangingCols);
}

TEST_F(NodeTest, LoadSceneOfAFilePathWorks) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  cloth_sim::LoadScene load;
  load.request.scene = ros::package::getPath("cloth_sim") + "/test/ros/scenes/small.yaml";
  const std::uint64_t since = states_->count();
  ASSERT_TRUE(callService(nodeTopic("load_scene"), load));
  ASSERT_TRUE(load.response.success) << load.response.message;
  const auto small = states_->waitFor([](const ClothState& s) { return s.rows == 6 && s.cols == 5; }, 10.0, since);
  ASSERT_TRUE(small) << "no 6x5 state after loading small.yaml";
  EXPECT_EQ(small->positions.size(), 30u);
}

// An audit's: ~colliders sent ADD markers only, and nothing when a scene had no colliders, so rviz kept
// drawing the spheres of a scene loaded before (a sphere fewer: that one; none: all of them). The first
// array after a scene change now begins with a DELETEALL.
TEST_F(NodeTest, LoadSceneOfASceneWithoutCollidersTakesTheOldOnesOffTheDisplay) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  Monitor<visualization_msgs::MarkerArray> colliders(nh_, nodeTopic("colliders"));
  const auto startsWithDeleteAll = [](const visualization_msgs::MarkerArray& a) {
    return !a.markers.empty() && a.markers.front().action == visualization_msgs::Marker::DELETEALL;
  };
  cloth_sim::LoadScene load;
  load.request.scene = "ball";
  ASSERT_TRUE(callService(nodeTopic("load_scene"), load));
  ASSERT_TRUE(load.response.success) << load.response.message;
  std::uint64_t drawn_index = 0;
  const auto drawn = colliders.waitFor(
      [](const visualization_msgs::MarkerArray& a) {
        return std::any_of(a.markers.begin(), a.markers.end(), [](const auto& m) { return m.ns == "spheres"; });
      },
      15.0, 0, &drawn_index);
  ASSERT_TRUE(drawn) << "the ball scene's sphere never came on ~colliders";
  EXPECT_TRUE(startsWithDeleteAll(*drawn)) << "the array adds its shapes without deleting the last ones";
  // Only the first array after a scene change deletes: each tick's would make rviz rebuild every shape.
  const auto next = colliders.waitForNext(10.0, drawn_index + 1);
  ASSERT_TRUE(next) << "no ~colliders array after the first";
  EXPECT_FALSE(startsWithDeleteAll(*next)) << "every array deletes the shapes it then adds again";
  const std::uint64_t before_load = colliders.count();
  load.request.scene = "hanging";
  ASSERT_TRUE(callService(nodeTopic("load_scene"), load));
  ASSERT_TRUE(load.response.success) << load.response.message;
  // The DELETEALL alone: an array of the ball scene still on its way holds one marker too (its sphere),
  // which a slow node (make sanitize) delivered after the load.
  const auto cleared = colliders.waitFor(
      [&](const visualization_msgs::MarkerArray& a) { return a.markers.size() == 1u && startsWithDeleteAll(a); }, 10.0,
      before_load);
  ASSERT_TRUE(cleared) << "no DELETEALL after loading a scene without colliders: the sphere stays drawn";
  // Only one: a scene without colliders sends nothing more.
  const std::uint64_t after_clear = colliders.count();
  const auto frame = states_->waitForNext(10.0, states_->count());
  ASSERT_TRUE(frame);
  ASSERT_TRUE(states_->waitFor([&](const ClothState& s) { return s.frame >= frame->frame + 10; }, 10.0,
                               states_->count()));
  EXPECT_EQ(colliders.count(), after_clear) << "a scene without colliders kept sending arrays";
}

namespace {

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

}  // namespace

class LoadSceneRefusal : public NodeTest {
 protected:
  void TearDown() override {
    for (const std::string& dir : dirs_) std::filesystem::remove_all(dir);
  }

  /// A fresh folder for files the node is asked to load (the node runs on this machine), removed after
  /// the test.
  std::string scratchDir() {
    char pattern[] = "/tmp/cloth_sim_load_scene_XXXXXX";
    const char* dir = mkdtemp(pattern);
    if (!dir) {
      ADD_FAILURE() << "cannot create a folder under /tmp";
      return "/nonexistent";
    }
    dirs_.push_back(dir);
    return dir;
  }

  /// Asks ~load_scene for `scene`, expects a refusal whose message holds every one of `expected`, and
  /// checks that the hanging scene keeps running (10 more frames, same grid). Returns the message.
  std::string expectRefusedAndOldSceneRuns(const std::string& scene, const std::vector<std::string>& expected) {
    SCOPED_TRACE("load_scene '" + scene.substr(0, 80) + "'");
    cloth_sim::LoadScene load;
    load.request.scene = scene;
    if (!callService(nodeTopic("load_scene"), load)) return "";
    EXPECT_FALSE(load.response.success) << load.response.message;
    EXPECT_NE(load.response.message.find("the current scene keeps running"), std::string::npos)
        << load.response.message;
    for (const std::string& text : expected) {
      EXPECT_NE(load.response.message.find(text), std::string::npos) << "'" << text << "' missing from "
                                                                     << load.response.message;
    }
    const std::uint64_t since = states_->count();
    const auto now = states_->waitForNext(10.0, since);
    EXPECT_TRUE(now) << "the node stopped publishing";
    if (!now) return load.response.message;
    const auto later = states_->waitFor([&](const ClothState& s) { return s.frame >= now->frame + 10; }, 15.0, since);
    EXPECT_TRUE(later) << "the old scene stopped advancing";
    if (later) {
      EXPECT_EQ(later->rows, kHangingRows);
      EXPECT_EQ(later->cols, kHangingCols);
    }
    return load.response.message;
  }

  std::vector<std::string> dirs_;
};

TEST_F(LoadSceneRefusal, AnEmptyNameADirectoryAndFilesThatAreNotScenes) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  expectRefusedAndOldSceneRuns("", {"empty"});
  expectRefusedAndOldSceneRuns(dir, {"not a scene file"});
  ASSERT_EQ(mkdir((dir + "/folder.yaml").c_str(), 0700), 0);
  expectRefusedAndOldSceneRuns(dir + "/folder.yaml", {"is a directory"});
  // Neither file is opened, so nothing of them can come back.
  const std::string passwd = expectRefusedAndOldSceneRuns("/etc/passwd", {"not a scene file"});
  EXPECT_EQ(passwd.find("root:"), std::string::npos) << passwd;
  expectRefusedAndOldSceneRuns("../../etc/hostname", {"not a scene file"});
}

TEST_F(LoadSceneRefusal, AForeignFileNamedYamlIsQuotedOnlyAsAShortExcerpt) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  const std::string secret = "the_part_that_must_not_leak";
  const std::string message = expectRefusedAndOldSceneRuns(
      writeFile(dir, "passwd.yaml", "root:x:0:0:root:/root:/bin/bash\nuser:x:1000:1000:" + secret + ":/home\n"),
      {"expected a map of scene keys", "root:x:0:0"});
  EXPECT_EQ(message.find(secret), std::string::npos) << message;
  EXPECT_LT(message.size(), 1000u) << message;
}

TEST_F(LoadSceneRefusal, AFileOverOneMebibyteIsRefusedBeforeItIsRead) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  // 2 MiB of a valid YAML comment: before, the node read and parsed all of it.
  const std::string message = expectRefusedAndOldSceneRuns(
      writeFile(dir, "big.yaml", "rows: 5\n#" + std::string(2 * 1024 * 1024, 'x') + "\n"),
      {"larger than the limit of 1048576 bytes"});
  EXPECT_LT(message.size(), 1000u);
}

TEST_F(LoadSceneRefusal, MalformedEmptyWrongTypesAndDuplicateKeys) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  expectRefusedAndOldSceneRuns(writeFile(dir, "malformed.yaml", "rows: [5\n"), {"not valid YAML"});
  expectRefusedAndOldSceneRuns(writeFile(dir, "empty.yaml", ""), {"empty"});
  expectRefusedAndOldSceneRuns(writeFile(dir, "types.yaml", "rows: five\n"), {"rows", "an integer"});
  expectRefusedAndOldSceneRuns(writeFile(dir, "duplicate.yaml", "name: d\nrows: 5\nrows: 6\n"),
                               {"duplicate key 'rows'"});
}

TEST_F(LoadSceneRefusal, AGoodSceneWithAMissingOrBadTextureKeepsTheOldSceneRunning) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  expectRefusedAndOldSceneRuns(writeFile(dir, "missing.yaml", "name: textured\nrows: 6\ntexture: missing.png\n"),
                               {"missing.png"});
  writeFile(dir, "bad.png", "this is not an image");
  expectRefusedAndOldSceneRuns(writeFile(dir, "bad.yaml", "name: textured\nrows: 6\ntexture: bad.png\n"),
                               {"texture"});
}

TEST_F(LoadSceneRefusal, AClothThatStartsInsideATableIsRefusedNamingTheTable) {
  // Before, the scene replaced the old one and sat at frame 0: every frame rolled back, every third
  // reset the scene, an ERROR each time.
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  expectRefusedAndOldSceneRuns(
      writeFile(dir, "through.yaml",
                "name: through\nrows: 6\ncols: 6\nwidth: 1.0\nheight: 1.0\norigin: [-0.5, 0.0, 1.5]\n"
                "u_axis: [1.0, 0.0, 0.0]\nv_axis: [0.0, 0.0, -1.0]\n"
                "boxes:\n  - {min: [-0.2, -0.2, 0.8], max: [0.2, 0.2, 1.2]}\n"),
      {"the cloth starts inside a collider", "box 0", "4 particles"});
}

TEST_F(LoadSceneRefusal, AFrameRateTheNodeCannotTimeIsRefusedAndTheOldSceneRuns) {
  // Before, validation passed, the new scene replaced the old one, then ros::Duration threw: the call
  // failed with no answer and the node sat at frame 0 saying "running".
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string dir = scratchDir();
  expectRefusedAndOldSceneRuns(writeFile(dir, "slow.yaml", "name: slow\nframe_rate: 1.0e-10\n"),
                               {"frame_rate", "[1, 1000]"});
}

// ---- 10. dynamic_reconfigure (services.test) ------------------------------------------------------

namespace {

dynamic_reconfigure::Reconfigure intParameter(const std::string& name, int value) {
  dynamic_reconfigure::Reconfigure reconfigure;
  dynamic_reconfigure::IntParameter parameter;
  parameter.name = name;
  parameter.value = value;
  reconfigure.request.config.ints.push_back(parameter);
  return reconfigure;
}

std::string stringIn(const dynamic_reconfigure::Config& config, const std::string& name) {
  for (const auto& parameter : config.strs) {
    if (parameter.name == name) return parameter.value;
  }
  return "<missing>";
}

}  // namespace

TEST_F(NodeTest, ReconfigureSubstepsChangesTheState) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const ClothState::ConstPtr first = states_->waitForNext(10.0, states_->count());
  ASSERT_TRUE(first);
  EXPECT_EQ(first->integrator, "implicit_euler") << "the scenes' default";
  ASSERT_EQ(first->substeps, 1u);
  auto reconfigure = intParameter("substeps", 2);
  const std::uint64_t since = states_->count();
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_TRUE(states_->waitFor([](const ClothState& s) { return s.substeps == 2; }, 10.0, since))
      << "ClothState.substeps stayed " << states_->latest()->substeps;
}

TEST_F(NodeTest, ReconfigureRefusesAnUnknownIntegrator) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string before = states_->waitForNext(10.0, states_->count())->integrator;
  dynamic_reconfigure::Reconfigure reconfigure;
  dynamic_reconfigure::StrParameter parameter;
  parameter.name = "integrator";
  parameter.value = "bogus";
  reconfigure.request.config.strs.push_back(parameter);
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  // The answer is the configuration in force: the old integrator, not the refused one.
  EXPECT_EQ(stringIn(reconfigure.response.config, "integrator"), before);
  // Alive, still on the old integrator.
  const std::uint64_t since = states_->count();
  const auto now = states_->waitForNext(10.0, since);
  ASSERT_TRUE(now);
  const auto later = states_->waitFor([&](const ClothState& s) { return s.frame >= now->frame + 5; }, 10.0, since);
  ASSERT_TRUE(later) << "the node stopped after the refused reconfigure";
  EXPECT_EQ(later->integrator, before);
}

TEST_F(NodeTest, ReconfigureSwitchesThePreconditionerAndRefusesAnUnknownOne) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  ASSERT_TRUE(states_->waitForNext(10.0, states_->count()));
  dynamic_reconfigure::Reconfigure reconfigure;
  dynamic_reconfigure::StrParameter parameter;
  parameter.name = "solver_preconditioner";
  parameter.value = "block_jacobi";
  reconfigure.request.config.strs.push_back(parameter);
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_EQ(stringIn(reconfigure.response.config, "solver_preconditioner"), "block_jacobi");
  reconfigure.request.config.strs.front().value = "jacobi";
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_EQ(stringIn(reconfigure.response.config, "solver_preconditioner"), "block_jacobi")
      << "a refused name leaves the one in force";
  const std::uint64_t since = states_->count();
  const auto now = states_->waitForNext(10.0, since);
  ASSERT_TRUE(now);
  EXPECT_TRUE(states_->waitFor([&](const ClothState& s) { return s.frame >= now->frame + 5; }, 10.0, since))
      << "the node stopped after the refused reconfigure";
  reconfigure.request.config.strs.front().value = "multigrid";
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_EQ(stringIn(reconfigure.response.config, "solver_preconditioner"), "multigrid");
}

TEST_F(NodeTest, ReconfigureSwitchesSelfCollisionOnAndRefusesANegativeThickness) {
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  ASSERT_TRUE(states_->waitForNext(10.0, states_->count()));
  const auto boolIn = [](const dynamic_reconfigure::Config& config, const std::string& name) {
    for (const auto& parameter : config.bools) {
      if (parameter.name == name) return static_cast<int>(parameter.value);
    }
    return -1;
  };
  const auto doubleIn = [](const dynamic_reconfigure::Config& config, const std::string& name) {
    for (const auto& parameter : config.doubles) {
      if (parameter.name == name) return parameter.value;
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  dynamic_reconfigure::Reconfigure reconfigure;
  dynamic_reconfigure::BoolParameter on;
  on.name = "self_collision";
  on.value = true;
  reconfigure.request.config.bools.push_back(on);
  dynamic_reconfigure::DoubleParameter thickness;
  thickness.name = "self_collision_thickness";
  thickness.value = 0.03;
  reconfigure.request.config.doubles.push_back(thickness);
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_EQ(boolIn(reconfigure.response.config, "self_collision"), 1);
  EXPECT_DOUBLE_EQ(doubleIn(reconfigure.response.config, "self_collision_thickness"), 0.03);
  reconfigure.request.config.doubles.front().value = -0.01;
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_DOUBLE_EQ(doubleIn(reconfigure.response.config, "self_collision_thickness"), 0.03)
      << "a refused thickness leaves the one in force";
  const std::uint64_t since = states_->count();
  const auto now = states_->waitForNext(10.0, since);
  ASSERT_TRUE(now);
  EXPECT_TRUE(states_->waitFor([&](const ClothState& s) { return s.frame >= now->frame + 5; }, 10.0, since))
      << "the node stopped with self-collision on";
  reconfigure.request.config.doubles.clear();
  reconfigure.request.config.bools.front().value = false;
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  EXPECT_EQ(boolIn(reconfigure.response.config, "self_collision"), 0);
}

TEST_F(NodeTest, ReconfigureKeepsTheWindFromTheTopic) {
  // A reconfigure of substeps carries the wind sliders too; they must not overwrite a wind that came
  // in on ~wind. Paused, so each check is a fixed number of frames.
  ClothState::ConstPtr frame0;
  ASSERT_NO_FATAL_FAILURE(freshScene(true, &frame0));
  ros::Publisher publisher = nh_.advertise<geometry_msgs::Vector3Stamped>(nodeTopic("wind"), 10);
  ASSERT_TRUE(waitForSubscribers(publisher, 1, 10.0));
  geometry_msgs::Vector3Stamped wind;
  wind.header.frame_id = "world";
  wind.vector.y = 5.0;
  publisher.publish(wind);
  // Wait until the wind acts (step until the cloth leaves the y = 0 plane).
  const auto deadline = deadlineIn(10.0);
  bool blowing = false;
  while (!blowing && Clock::now() < deadline) {
    const auto s = step(1);
    ASSERT_TRUE(s);
    blowing = meanY(*s) > 0.0;
  }
  ASSERT_TRUE(blowing) << "the wind never acted";

  auto reconfigure = intParameter("substeps", 2);
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  ASSERT_TRUE(reset());  // reset keeps tuning and wind
  const auto s = step(25);
  ASSERT_TRUE(s);
  EXPECT_GT(meanY(*s), 1e-3) << "the reconfigure switched the topic's wind off";
}

TEST_F(NodeTest, ReconfigureWindSliderBlows) {
  // The other half of the rule above: moving the wind sliders does set the wind.
  ASSERT_NO_FATAL_FAILURE(freshScene(true));
  dynamic_reconfigure::Reconfigure reconfigure;
  dynamic_reconfigure::DoubleParameter parameter;
  parameter.name = "wind_y";
  parameter.value = 5.0;
  reconfigure.request.config.doubles.push_back(parameter);
  ASSERT_TRUE(callService(nodeTopic("tuning/set_parameters"), reconfigure));
  const auto s = step(25);
  ASSERT_TRUE(s);
  EXPECT_GT(meanY(*s), 1e-3) << "the wind_y slider did not blow";
}

// ---- 11. Diagnostics (services.test) --------------------------------------------------------------

TEST_F(NodeTest, DiagnosticsReportTheSimulation) {
  Monitor<diagnostic_msgs::DiagnosticArray> diagnostics(nh_, "/diagnostics");
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string name = nodeName().substr(1) + ": simulation";
  const auto find = [&](const diagnostic_msgs::DiagnosticArray& array) -> const diagnostic_msgs::DiagnosticStatus* {
    for (const auto& status : array.status) {
      if (status.name == name) return &status;
    }
    return nullptr;
  };
  // The first window after a load may include the scene change; wait (diagnostics come at 1 Hz) for an
  // OK one.
  const auto ok = diagnostics.waitFor(
      [&](const diagnostic_msgs::DiagnosticArray& a) {
        const auto* s = find(a);
        return s && s->level == diagnostic_msgs::DiagnosticStatus::OK;
      },
      20.0, diagnostics.count());
  ASSERT_TRUE(ok) << "no OK status named '" << name << "' on /diagnostics";
  const auto* status = find(*ok);
  std::map<std::string, std::string> values;
  for (const auto& kv : status->values) values[kv.key] = kv.value;
  for (const char* key : {"step cost [ms]", "real-time factor", "max strain"}) {
    ASSERT_TRUE(values.count(key)) << "missing key '" << key << "'";
  }
  const double cost_ms = std::stod(values["step cost [ms]"]);
  const double real_time_factor = std::stod(values["real-time factor"]);
  const double strain = std::stod(values["max strain"]);
  EXPECT_TRUE(std::isfinite(cost_ms) && cost_ms > 0.0) << cost_ms;
  EXPECT_TRUE(std::isfinite(real_time_factor) && real_time_factor > 0.0) << real_time_factor;
  EXPECT_TRUE(std::isfinite(strain) && strain >= 0.0 && strain < 0.5) << strain;
}

// A review's: ~load_state replaces the options (integrator, substeps, tuning) but kept the frame cost of
// the setup before it, which ~step then used to estimate a call's time (install() forgets it for a new
// scene). Paused, no frame runs after the load: the cost reported must be none (0), not the old frames'.
TEST_F(NodeTest, DiagnosticsStepCostIsForgottenWhenLoadStateReplacesTheSetup) {
  Monitor<diagnostic_msgs::DiagnosticArray> diagnostics(nh_, "/diagnostics");
  ASSERT_NO_FATAL_FAILURE(freshScene(true));
  const std::string name = nodeName().substr(1) + ": simulation";
  // The step cost in the first report stamped after `after` (diagnostics come at 1 Hz); NaN if none came.
  const auto costAfter = [&](const ros::Time& after) {
    double cost_ms = std::numeric_limits<double>::quiet_NaN();
    diagnostics.waitFor(
        [&](const diagnostic_msgs::DiagnosticArray& a) {
          if (a.header.stamp <= after) return false;
          for (const auto& status : a.status) {
            if (status.name != name) continue;
            for (const auto& kv : status.values) {
              if (kv.key == "step cost [ms]") cost_ms = std::stod(kv.value);
            }
            return true;
          }
          return false;
        },
        20.0, 0);
    return cost_ms;
  };
  ASSERT_TRUE(step(5));
  const double before_ms = costAfter(ros::Time::now());
  ASSERT_GT(before_ms, 0.0) << "no frame cost reported after 5 frames: the test would prove nothing";

  const std::string path = (std::filesystem::temp_directory_path() /
                            ("cloth_sim_step_cost_" + std::to_string(getpid()) + ".state")).string();
  cloth_sim::SaveState save;
  save.request.path = path;
  ASSERT_TRUE(callService(nodeTopic("save_state"), save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  cloth_sim::LoadState load;
  load.request.path = path;
  ASSERT_TRUE(callService(nodeTopic("load_state"), load));
  std::filesystem::remove(path);
  ASSERT_TRUE(load.response.success) << load.response.message;
  EXPECT_EQ(costAfter(ros::Time::now()), 0.0) << "the frames before ~load_state cost " << before_ms << " ms each";
}

// ---- 11b. A cloth at rest sleeps, and a grasp wakes it (services.test) ----------------------------

TEST_F(NodeTest, AClothAtRestSleepsAndAGraspWakesIt) {
  Monitor<diagnostic_msgs::DiagnosticArray> diagnostics(nh_, "/diagnostics");
  ASSERT_NO_FATAL_FAILURE(freshScene(false));
  const std::string name = nodeName().substr(1) + ": simulation";
  const auto asleepIs = [&](const char* value) {
    return [&name, value](const diagnostic_msgs::DiagnosticArray& array) {
      for (const auto& status : array.status) {
        if (status.name != name) continue;
        for (const auto& kv : status.values) {
          if (kv.key == "asleep") return kv.value == value;
        }
      }
      return false;
    };
  };
  // The hanging cloth swings out its start within a few seconds and then sleeps (sleep_speed's default).
  const auto asleep = diagnostics.waitFor(asleepIs("True"), 40.0, diagnostics.count());
  ASSERT_TRUE(asleep) << "the hanging cloth never slept";
  // Asleep: ~state keeps coming, frame after frame, with the same positions (bit for bit, but for the frame
  // computed once a second to check the cloth is still at rest: the hanging cloth comes to an exact rest,
  // so that frame moves it less than sleep_speed, 1e-4 m/s, over 0.02 s, or it would wake) and the
  // substeps the cloth was last computed with.
  const auto first = states_->waitForNext(5.0, states_->count());
  ASSERT_TRUE(first);
  const auto later = states_->waitFor([&](const ClothState& s) { return s.frame >= first->frame + 10; }, 5.0,
                                      states_->count());
  ASSERT_TRUE(later) << "~state stopped while the cloth slept";
  double moved_m = 0.0;
  for (std::size_t i = 0; i < first->positions.size(); ++i) {
    moved_m = std::max(moved_m, distance(first->positions[i], later->positions[i]));
  }
  EXPECT_LT(moved_m, 2e-6) << "a sleeping cloth moved";
  EXPECT_GE(later->substeps, 1u);
  // A grasp wakes it: the corner follows the hand, and the diagnostics say it is awake.
  const int particle = static_cast<int>((kHangingRows - 1) * kHangingCols);  // bottom-left corner, free
  ros::Publisher grasp_pub = nh_.advertise<cloth_sim::Grasp>(nodeTopic("grasp"), 10);
  ASSERT_TRUE(waitForSubscribers(grasp_pub, 1, 10.0));
  geometry_msgs::Point target = later->positions[particle];
  target.y += 0.2;
  const cloth_sim::Grasp grab = grabMessage(3, particle, target, 500.0);
  const std::uint64_t since = states_->count();
  const std::uint64_t diagnostics_since = diagnostics.count();
  grasp_pub.publish(grab);
  const auto moved = states_->waitFor(
      [&](const ClothState& s) { return distance(s.positions[particle], later->positions[particle]) > 0.05; }, 10.0,
      since);
  EXPECT_TRUE(moved) << "the grasp did not wake the cloth";
  EXPECT_TRUE(diagnostics.waitFor(asleepIs("False"), 5.0, diagnostics_since)) << "awake, the diagnostics said asleep";
}

// ---- 7. Ball scene: the sphere's tf frame moves (ball.test) ---------------------------------------

TEST(Ball, SphereFrameMoves) {
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  const std::string frame = privateParam("frame_id", "world");
  ASSERT_TRUE(waitUntil([&] { return buffer.canTransform(frame, "sphere_0", ros::Time(0)); }, 15.0))
      << "no tf " << frame << " -> sphere_0";
  // ball.yaml swings the sphere +-0.75 m along y with a 6 s period. Two instants symmetric about a turning
  // point see it in the same place, so sample three, 0.5 s apart: some pair is then at least ~0.1 m apart.
  const ros::Time t1 = buffer.lookupTransform(frame, "sphere_0", ros::Time(0)).header.stamp;
  std::vector<Eigen::Vector3d> centers;
  for (int k = 0; k < 3; ++k) {
    const ros::Time t = t1 + ros::Duration(0.5 * k);
    ASSERT_TRUE(waitUntil([&] { return buffer.canTransform(frame, "sphere_0", t); }, 15.0)) << "tf stopped before " << t;
    const auto transform = buffer.lookupTransform(frame, "sphere_0", t);
    EXPECT_EQ(transform.header.frame_id, frame);
    EXPECT_EQ(transform.child_frame_id, "sphere_0");
    centers.emplace_back(transform.transform.translation.x, transform.transform.translation.y,
                         transform.transform.translation.z);
  }
  double largest_m = 0.0;
  for (const auto& a : centers)
    for (const auto& b : centers) largest_m = std::max(largest_m, (a - b).norm());
  EXPECT_GT(largest_m, 0.02) << "sphere_0 did not move over 1 s from " << t1;
}

TEST(Ball, TwoNodesPublishTheirSpheresUnderTheirOwnPrefixes) {
  // ball.test also runs /left/cloth_node in frame left_world with ~sphere_frame_prefix left_sphere_. Before
  // the parameter, both nodes sent sphere_0 (children of world and of left_world in turn), so each moved
  // the other's frame. Every sphere frame must have its own node's frame as its only parent.
  std::mutex mutex;
  std::map<std::string, std::set<std::string>> parents_of;  // child frame -> the parents it was sent with
  ros::NodeHandle nh;
  const ros::Subscriber tf_sub =
      nh.subscribe<tf2_msgs::TFMessage>("/tf", 100, [&](const tf2_msgs::TFMessage::ConstPtr& message) {
        const std::lock_guard<std::mutex> lock(mutex);
        for (const auto& t : message->transforms) parents_of[t.child_frame_id].insert(t.header.frame_id);
      });
  const auto both_seen = [&] {
    const std::lock_guard<std::mutex> lock(mutex);
    return parents_of.count("sphere_0") > 0 && parents_of.count("left_sphere_0") > 0;
  };
  ASSERT_TRUE(waitUntil(both_seen, 15.0)) << "sphere_0 and left_sphere_0 were not both on /tf";
  std::this_thread::sleep_for(std::chrono::seconds(1));  // a second of both nodes' frames
  const std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(parents_of["sphere_0"], std::set<std::string>{"world"});
  EXPECT_EQ(parents_of["left_sphere_0"], std::set<std::string>{"left_world"});
}

// ---- 8. Determinism under /use_sim_time (sim_time.test) -------------------------------------------

/// Drives /clock for the sim-time tests, one exact 0.02 s frame (kTick) at a time.
class ClockDriver {
 public:
  static inline const ros::Duration kTick{0, 20000000};

  explicit ClockDriver(ros::NodeHandle& nh) : publisher_(nh.advertise<rosgraph_msgs::Clock>("/clock", 10)) {}

  void publish(const ros::Time& time) {
    rosgraph_msgs::Clock clock;
    clock.clock = time;
    publisher_.publish(clock);
  }

  /// Holds /clock at `time` until `states` has a state stamped with it (a node anchors on the first clock
  /// it sees, and early clocks may be lost); searches from *index and leaves it at the state found. Null
  /// if none came within 20 s.
  ClothState::ConstPtr settleAt(const ros::Time& time, Monitor<ClothState>& states, std::uint64_t* index) {
    ClothState::ConstPtr state;
    const auto deadline = deadlineIn(20.0);
    while (!state && Clock::now() < deadline) {
      publish(time);
      state = states.waitFor([&](const ClothState& s) { return s.header.stamp == time; }, 0.2, *index, index);
    }
    return state;
  }

 private:
  ros::Publisher publisher_;
};

TEST(SimTime, ResetAndRerunIsBitIdentical) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  ClockDriver clock(nh);
  // The node publishes its state only to subscribers: wait until ours is connected.
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1; }, 15.0)) << "node not publishing ~state";

  const ros::Time t0(100, 0);
  std::uint64_t index = 0;
  const ClothState::ConstPtr first = clock.settleAt(t0, states, &index);
  ASSERT_TRUE(first) << "no state stamped with the first clock";
  ASSERT_EQ(first->frame, 0u);

  // Advances the clock one frame at a time, waiting for each frame's state before the next tick.
  constexpr std::uint64_t kFrames = 50;
  ros::Time now = t0;
  const auto run = [&](std::uint64_t* since) -> ClothState::ConstPtr {
    ClothState::ConstPtr state;
    for (std::uint64_t k = 1; k <= kFrames; ++k) {
      now += ClockDriver::kTick;
      clock.publish(now);
      state = states.waitFor([&](const ClothState& s) { return s.frame >= k; }, 10.0, *since, since);
      if (!state) {
        ADD_FAILURE() << "no state for frame " << k;
        return nullptr;
      }
      EXPECT_EQ(state->frame, k) << "one tick advanced more than one frame";
      ++*since;
    }
    return state;
  };
  std::uint64_t since = index + 1;
  const auto first_run = run(&since);
  ASSERT_TRUE(first_run);
  EXPECT_FALSE(sameBits(*first, *first_run)) << "the cloth did not move: the comparison would prove nothing";

  // reset re-anchors frame 0 at the current clock; keep advancing it from there.
  std_srvs::Trigger trigger;
  ASSERT_TRUE(callService(nodeTopic("reset"), trigger));
  ASSERT_TRUE(trigger.response.success);
  const auto reset = states.waitFor([](const ClothState& s) { return s.frame == 0; }, 10.0, since, &index);
  ASSERT_TRUE(reset) << "no frame-0 state after reset";
  EXPECT_TRUE(sameBits(*first, *reset));
  since = index + 1;
  const auto second_run = run(&since);
  ASSERT_TRUE(second_run);
  EXPECT_EQ(second_run->frame, first_run->frame);
  EXPECT_EQ(second_run->sim_time, first_run->sim_time);
  EXPECT_TRUE(sameBits(*first_run, *second_run));
}

TEST(SimTime, ALeapingOrRewoundClockStillGivesOneFramePerTick) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1; }, 15.0)) << "node not publishing ~state";
  std::uint64_t index = 0;
  const auto settleAt = [&](const ros::Time& time) { return clock.settleAt(time, states, &index); };
  constexpr std::uint64_t kTicks = 10;
  // From a settled clock, each 0.02 s tick must advance exactly one frame.
  const auto expectOneFramePerTick = [&](ros::Time time, std::uint64_t frame) {
    for (std::uint64_t k = 1; k <= kTicks; ++k) {
      time += ClockDriver::kTick;
      clock.publish(time);
      const auto state = states.waitFor([&](const ClothState& s) { return s.header.stamp == time; }, 10.0, index, &index);
      ASSERT_TRUE(state) << "no state at " << time;
      EXPECT_EQ(state->frame, frame + k);
    }
  };
  // A leap of far more than kMaxSimTimeCatchUpFrames (500) frames is not simulated frame by frame.
  const ros::Time settled(300, 0);
  const auto before = settleAt(settled);
  ASSERT_TRUE(before);
  const ros::Time leapt = settled + ros::Duration(100.0);  // 5000 frames ahead
  const auto after_leap = settleAt(leapt);
  ASSERT_TRUE(after_leap) << "the node stalled on a leap of /clock";
  EXPECT_EQ(after_leap->frame, before->frame + 500);
  ASSERT_NO_FATAL_FAILURE(expectOneFramePerTick(leapt, after_leap->frame));
  // Backwards (a looping bag): no frame is lost, invented or repeated, and counting goes on from there.
  // roscpp restarts its timers a period after the jump it notices, so tick on until the node answers: the
  // tick that notices counts frames from its time and has no new frame to send, the next sends one.
  ros::Time rewound(200, 0);
  ClothState::ConstPtr after_rewind;
  for (std::uint64_t k = 0; k < kTicks && !after_rewind; ++k) {
    rewound += ClockDriver::kTick;
    clock.publish(rewound);
    after_rewind = states.waitFor([&](const ClothState& s) { return s.header.stamp == rewound; }, 1.0, index, &index);
  }
  ASSERT_TRUE(after_rewind) << "the node stopped publishing after /clock went back";
  EXPECT_EQ(after_rewind->frame, after_leap->frame + kTicks + 1);
  ASSERT_NO_FATAL_FAILURE(expectOneFramePerTick(rewound, after_rewind->frame));
}

// An audit's: /clock sent back after leaps of several frames left the node silent, without a frame or a
// warning, for 25 ticks in 2 of 3 runs (roscpp's timer thread missed the jump and waited half a second of
// the new clock). The node re-arms its timer when it sees the clock go back: it answers within a few
// (sim_time_rewind.test: a fresh node, always awake; after SimTime.*'s clock games the silence did not show).
TEST(SimTimeRewind, AClockSentBackAfterLeapsIsAnsweredWithinAFewTicks) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_rewind.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"), 1000);
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1; }, 15.0)) << "node not publishing ~state";
  // The clock as a simulator or a bag sends it, paced in wall time (the pacing is the input here, not a
  // wait for the node): ten frames, three leaps of five, 5 s back, then frame by frame.
  const auto paced = [&](const ros::Time& time) {
    clock.publish(time);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  };
  // The tick that notices the jump counts frames from its own time and the next sends a frame (measured:
  // the second tick); more where the node's 50 ms look at the clock comes late on a loaded machine. Before,
  // 25 ticks of silence.
  constexpr int kMostTicksToAnswer = 6;
  constexpr int kTicksAfter = 10;
  std::uint64_t index = 0;
  ros::Time now(1000, 0);
  ASSERT_TRUE(clock.settleAt(now, states, &index)) << "no state stamped with the first clock";
  for (int k = 0; k < 10; ++k) paced(now += ClockDriver::kTick);
  for (int k = 0; k < 3; ++k) paced(now += ros::Duration(0.1));
  ASSERT_TRUE(states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index))
      << "no state at " << now;
  const ros::Time rewound = now - ros::Duration(5.0);
  paced(rewound);
  for (int k = 1; k <= kTicksAfter; ++k) paced(rewound + ros::Duration(k * ClockDriver::kTick.toSec()));
  const ros::Time last = rewound + ros::Duration(kTicksAfter * ClockDriver::kTick.toSec());
  const auto latest = states.waitFor([&](const ClothState& s) { return s.header.stamp == last; }, 10.0, index + 1);
  ASSERT_TRUE(latest) << "no state at " << last << " after /clock went back 5 s";
  const auto first =
      states.waitFor([&](const ClothState& s) { return s.header.stamp > rewound; }, 0.0, index + 1);
  ASSERT_TRUE(first);
  EXPECT_LE(first->header.stamp, rewound + ros::Duration(kMostTicksToAnswer * ClockDriver::kTick.toSec()))
      << "the first state after /clock went back to " << rewound << " came at " << first->header.stamp;
}

// An audit's: under /use_sim_time, when /clock leapt several frames at once, roscpp fired the node's timer
// again with no new time, and the node sent its spheres' tf and its colliders a second time with the same
// stamp; every tf listener (the node's own too) then logged TF_REPEATED_DATA for each sphere
// (sim_time_tf.test: ball).
TEST(SimTimeTf, TheSpheresTfAndTheCollidersGoOutOncePerStampWhenTheClockLeaps) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_tf.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  Monitor<tf2_msgs::TFMessage> tfs(nh, "/tf", 1000);
  Monitor<visualization_msgs::MarkerArray> colliders(nh, nodeTopic("colliders"), 1000);
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] {
    return states.publisherCount() >= 1 && tfs.publisherCount() >= 1 && colliders.publisherCount() >= 1;
  }, 15.0)) << "the node publishes no ~state, no /tf or no ~colliders";
  std::uint64_t index = 0;
  ros::Time now(100, 0);
  ASSERT_TRUE(clock.settleAt(now, states, &index)) << "no state stamped with the first clock";
  constexpr int kLeaps = 6;
  const ros::Duration leap(0.1);  // five frames at once
  for (int k = 0; k < kLeaps; ++k) {
    now += leap;
    clock.publish(now);
    ASSERT_TRUE(states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index))
        << "no state at " << now;
  }
  // One more frame, and its sphere: every tf sent before it has arrived (one publisher keeps its order).
  now += ClockDriver::kTick;
  clock.publish(now);
  const auto is_sphere_at = [](const tf2_msgs::TFMessage& m, const ros::Time& stamp) {
    for (const auto& t : m.transforms) {
      if (t.child_frame_id == "sphere_0" && t.header.stamp == stamp) return true;
    }
    return false;
  };
  ASSERT_TRUE(tfs.waitFor([&](const tf2_msgs::TFMessage& m) { return is_sphere_at(m, now); }, 10.0))
      << "no sphere_0 tf at " << now;
  std::map<ros::Time, int> sent;
  tfs.waitFor([&](const tf2_msgs::TFMessage& m) {
    for (const auto& t : m.transforms) {
      if (t.child_frame_id == "sphere_0") ++sent[t.header.stamp];
    }
    return false;  // look at every message received
  }, 0.0);
  EXPECT_GE(sent.size(), static_cast<std::size_t>(kLeaps + 1)) << "a sphere tf after each leap and the last frame";
  for (const auto& [stamp, times] : sent) EXPECT_EQ(times, 1) << "sphere_0 sent " << times << " times at " << stamp;
  // The colliders' markers too, once per stamp (they came twice with the tf).
  ASSERT_TRUE(colliders.waitFor([&](const visualization_msgs::MarkerArray& m) {
    return !m.markers.empty() && m.markers.front().header.stamp == now;
  }, 10.0)) << "no ~colliders at " << now;
  std::map<ros::Time, int> drawn;
  colliders.waitFor([&](const visualization_msgs::MarkerArray& m) {
    if (!m.markers.empty()) ++drawn[m.markers.front().header.stamp];
    return false;  // look at every message received
  }, 0.0);
  EXPECT_GE(drawn.size(), static_cast<std::size_t>(kLeaps + 1)) << "~colliders after each leap and the last frame";
  for (const auto& [stamp, times] : drawn) EXPECT_EQ(times, 1) << "~colliders sent " << times << " times at " << stamp;
}

// A review's: with the once-per-stamp rule above, a ~step under a held /clock (paused, the clock not
// moving: the deterministic way to drive the node frame by frame) sent only ~state; ~points, ~colliders
// and ~mesh kept showing the cloth from before the step, and no later tick came to mend it.
TEST(SimTimeTf, AStepUnderAHeldClockSendsItsNewFrameOnEveryTopic) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_tf.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  Monitor<sensor_msgs::PointCloud2> points(nh, nodeTopic("points"));
  Monitor<visualization_msgs::MarkerArray> colliders(nh, nodeTopic("colliders"));
  Monitor<visualization_msgs::Marker> meshes(nh, nodeTopic("mesh"));
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] {
    return states.publisherCount() >= 1 && points.publisherCount() >= 1 && colliders.publisherCount() >= 1 &&
           meshes.publisherCount() >= 1;
  }, 15.0)) << "the node publishes no ~state, ~points, ~colliders or ~mesh";
  std::uint64_t index = 0;
  const ros::Time held(101, 0);  // after the leaps of the test above, if it ran
  ASSERT_TRUE(clock.settleAt(held, states, &index)) << "no state stamped with the held clock";
  std_srvs::SetBool pause;
  pause.request.data = true;
  ASSERT_TRUE(callService(nodeTopic("pause"), pause));
  ASSERT_TRUE(pause.response.success) << pause.response.message;
  const auto before = points.waitFor([&](const sensor_msgs::PointCloud2& p) { return p.header.stamp == held; }, 10.0);
  ASSERT_TRUE(before) << "no ~points at the held clock";
  const std::uint64_t points_seen = points.count();
  const std::uint64_t colliders_seen = colliders.count();
  const std::uint64_t meshes_seen = meshes.count();
  cloth_sim::Step step;
  step.request.frames = 10;
  ASSERT_TRUE(callService(nodeTopic("step"), step));
  ASSERT_TRUE(step.response.success) << step.response.message;
  const auto after = points.waitFor([&](const sensor_msgs::PointCloud2& p) { return p.data != before->data; }, 10.0,
                                    points_seen);
  EXPECT_TRUE(after) << "~points still shows the cloth from before the step";
  EXPECT_TRUE(colliders.waitForNext(10.0, colliders_seen)) << "no ~colliders after the step";
  EXPECT_TRUE(meshes.waitForNext(10.0, meshes_seen)) << "no ~mesh after the step";
  pause.request.data = false;
  ASSERT_TRUE(callService(nodeTopic("pause"), pause));
}

TEST(SimTimeTwins, TwoNodeProcessesOnOneClockGiveIdenticalStates) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_twins.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> first(nh, nodeTopic("state"));
  Monitor<ClothState> twin(nh, privateParam("twin", "/cloth_twin") + "/state");
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] { return first.publisherCount() >= 1 && twin.publisherCount() >= 1; }, 15.0))
      << "both nodes must publish ~state";
  // Each node anchors frame 0 on the first clock it sees. Hold t0 until the first answers; the twin heard
  // the same clocks, so its state stamped t0 is then already in (or on its way to) its monitor.
  const ros::Time t0(100, 0);
  std::uint64_t first_index = 0;
  std::uint64_t twin_index = 0;
  ClothState::ConstPtr a = clock.settleAt(t0, first, &first_index);
  ClothState::ConstPtr b = clock.settleAt(t0, twin, &twin_index);
  ASSERT_TRUE(a && b) << "a node did not answer the first clock";
  ASSERT_EQ(a->frame, 0u);
  ASSERT_EQ(b->frame, 0u);
  ASSERT_TRUE(sameBits(*a, *b));
  const ClothState::ConstPtr start = a;

  constexpr std::uint64_t kFrames = 50;
  ros::Time now = t0;
  for (std::uint64_t k = 1; k <= kFrames; ++k) {
    now += ClockDriver::kTick;
    clock.publish(now);
    a = first.waitFor([&](const ClothState& s) { return s.frame >= k; }, 10.0, first_index + 1, &first_index);
    b = twin.waitFor([&](const ClothState& s) { return s.frame >= k; }, 10.0, twin_index + 1, &twin_index);
    ASSERT_TRUE(a && b) << "no state for frame " << k;
    ASSERT_EQ(a->frame, k) << "one tick advanced more than one frame";
    ASSERT_EQ(b->frame, k) << "one tick advanced more than one frame";
    ASSERT_TRUE(sameBits(*a, *b)) << "the two runs differ at frame " << k;
  }
  EXPECT_FALSE(sameBits(*start, *a)) << "the cloth did not move: the comparison would prove nothing";
}

// ---- 8b. A /clock past 2^31 s (sim_time_late.test) ------------------------------------------------

// An audit's: ros::Time minus ros::Time throws std::runtime_error when the difference is beyond +-2^31 s
// (a ros::Duration's seconds are an int32), and an exception out of the timer callback ends the node. Under a
// /clock at 2^31 s or later the node died at its first tick (the mouse marker's refresh measured from a zero
// time), and a leap of /clock by more than 2^31 s killed it in its frame count, in the grippers' and frame
// colliders' tf ages, in the cameras' due times and pose ages, and in tf2's own message for a lookup that
// far ahead of its data. ros::Time's seconds are a uint32, so such clocks run to about 4.29e9 s.

namespace {

/// 2^31 s: the first whole second a ros::Duration cannot hold.
constexpr std::uint32_t k2To31_s = 2147483648u;

/// Tf frames the test moves (sim_time_late.test): `hand` holds two particles (gripper id 1),
/// `sweeper` carries the frame collider (far from the cloth) and `eye_optical` the camera `eye`.
void sendFrames(tf2_ros::TransformBroadcaster& broadcaster, const ros::Time& stamp) {
  std::vector<geometry_msgs::TransformStamped> frames(3);
  for (auto& frame : frames) {
    frame.header.stamp = stamp;
    frame.header.frame_id = "world";
    frame.transform.rotation.w = 1.0;
  }
  frames[0].child_frame_id = "hand";
  frames[0].transform.translation.z = 1.5;
  frames[1].child_frame_id = "sweeper";
  frames[1].transform.translation.y = 2.0;
  frames[2].child_frame_id = "eye_optical";  // 2 m in front of the cloth, looking at it (optical z = world +y)
  frames[2].transform.translation.y = -2.0;
  frames[2].transform.translation.z = 1.0;
  frames[2].transform.rotation.x = -std::sin(M_PI / 4.0);
  frames[2].transform.rotation.w = std::cos(M_PI / 4.0);
  broadcaster.sendTransform(frames);
}

}  // namespace

// First in its file: the node must not have seen a clock before.
TEST(SimTimeLate, AFirstClockPast2To31SecondsIsSimulatedFrameByFrame) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_late.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  ClockDriver clock(nh);
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1; }, 15.0)) << "node not publishing ~state";
  const ros::Time first(k2To31_s + 10u, 0);
  std::uint64_t index = 0;
  const auto settled = clock.settleAt(first, states, &index);
  ASSERT_TRUE(settled) << "no state stamped with the first clock, " << first;
  ros::Time now = first;
  for (std::uint64_t k = 1; k <= 10; ++k) {
    now += ClockDriver::kTick;
    clock.publish(now);
    const auto state = states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index);
    ASSERT_TRUE(state) << "no state at " << now << ": the node died or stopped";
    EXPECT_EQ(state->frame, settled->frame + k);
  }
}

TEST(SimTimeLate, ALeapOfMoreThan2To31SecondsIsCountedFromTheNewTime) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_late.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  Monitor<sensor_msgs::CameraInfo> images(nh, nodeTopic("eye/depth/camera_info"));
  ClockDriver clock(nh);
  tf2_ros::TransformBroadcaster broadcaster;
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1 && images.publisherCount() >= 1; }, 15.0))
      << "the node publishes no ~state or no ~eye/depth/camera_info";
  // Back from the test above, if it ran (by less than 2^31 s: tf2_ros's listener computes that jump as a
  // ros::Duration too). After a jump back the node counts frames from its first tick after the new time
  // (README "use_sim_time"): tick until it answers.
  ros::Time now(100, 0);
  std::uint64_t index = 0;
  ClothState::ConstPtr answered;
  for (int k = 0; k < 50 && !answered; ++k) {
    now += ClockDriver::kTick;
    clock.publish(now);
    answered = states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 1.0, index, &index);
  }
  ASSERT_TRUE(answered) << "no state after /clock went back to 100 s";
  // A gripper on `hand` holding the top row's middle (the tf reaches the node's listener some time after
  // the first send; each try sends it at a new time, tf2 refuses a stamp it has).
  cloth_sim::Attach attach;
  attach.request.id = 1;
  attach.request.frame = "hand";
  attach.request.particles = {4, 5};
  const auto deadline = deadlineIn(15.0);
  while (!attach.response.success && Clock::now() < deadline) {
    now += ClockDriver::kTick;
    sendFrames(broadcaster, now);
    clock.publish(now);
    ASSERT_TRUE(callService(nodeTopic("attach"), attach));
    if (!attach.response.success) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(attach.response.success) << attach.response.message;
  // Frame by frame with the frames in tf at each frame's time, until the camera has rendered: gripper,
  // frame collider and camera each hold tf data from before the leap.
  const std::uint64_t images_before = images.count();
  ClothState::ConstPtr before;
  for (int k = 0; k < 50 && !images.waitFor([](const sensor_msgs::CameraInfo&) { return true; }, 0.0, images_before);
       ++k) {
    now += ClockDriver::kTick;
    sendFrames(broadcaster, now);
    clock.publish(now);
    before = states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index);
    ASSERT_TRUE(before) << "no state at " << now;
  }
  ASSERT_TRUE(images.waitForNext(10.0, images_before)) << "the camera rendered nothing before the leap";
  ASSERT_TRUE(before);

  // The leap, with no new tf: kMaxSimTimeCatchUpFrames (500) frames are simulated and the count goes on
  // from the new time, as for any leap (README "use_sim_time").
  const ros::Time leapt(now.sec + k2To31_s + 1000u, now.nsec);
  const auto after_leap = clock.settleAt(leapt, states, &index);
  ASSERT_TRUE(after_leap) << "no state at " << leapt << " after a leap of 2^31 s + 1000 s: the node died";
  EXPECT_EQ(after_leap->frame, before->frame + 500);
  // Frame by frame on: the gripper's, the collider's and the camera's newest tf are 2^31 s old (too old to
  // use; the gripper and the collider stay where they were, the camera renders nothing).
  now = leapt;
  for (std::uint64_t k = 1; k <= 10; ++k) {
    now += ClockDriver::kTick;
    clock.publish(now);
    const auto state = states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index);
    ASSERT_TRUE(state) << "no state at " << now << ": the node died or stopped";
    EXPECT_EQ(state->frame, after_leap->frame + k);
  }
  // The frames come back at the new time: the camera renders them again.
  const std::uint64_t images_after = images.count();
  const ros::Time resumed = now;
  sensor_msgs::CameraInfo::ConstPtr image;
  for (int k = 0; k < 50 && !image; ++k) {
    now += ClockDriver::kTick;
    sendFrames(broadcaster, now);
    clock.publish(now);
    ASSERT_TRUE(states.waitFor([&](const ClothState& s) { return s.header.stamp == now; }, 10.0, index, &index))
        << "no state at " << now;
    image = images.waitFor([&](const sensor_msgs::CameraInfo& i) { return i.header.stamp > resumed; }, 0.0,
                           images_after);
  }
  EXPECT_TRUE(image) << "the camera rendered nothing after the frames came back at the new time";
}

// A review's: ~attach measured a frame's age at the service call, the gripper's first frame at that frame's
// end, so a transform 0.49 s old was taken and called lost 0.02 s later (its particles held where it was
// seen). Under /clock both ages are exact: 0.49 s now is 0.51 s at the next frame's end, refused; 0.47 s is
// taken.
TEST(SimTimeLate, AttachTakesAFramesAgeAtTheNextFramesEnd) {
  ASSERT_TRUE(ros::Time::isSimTime()) << "sim_time_late.test must set /use_sim_time";
  ros::NodeHandle nh;
  Monitor<ClothState> states(nh, nodeTopic("state"));
  ClockDriver clock(nh);
  tf2_ros::TransformBroadcaster broadcaster;
  ASSERT_TRUE(waitUntil([&] { return states.publisherCount() >= 1; }, 15.0)) << "node not publishing ~state";
  std::uint64_t index = 0;
  const ros::Time now(k2To31_s + 5000u, 0);
  sendFrames(broadcaster, now);
  ASSERT_TRUE(clock.settleAt(now, states, &index)) << "no state stamped with " << now;
  const auto attachStale = [&](std::uint32_t id, const std::string& frame, double age_s) {
    geometry_msgs::TransformStamped transform;
    transform.header.stamp = now - ros::Duration(age_s);
    transform.header.frame_id = "world";
    transform.child_frame_id = frame;
    transform.transform.translation.z = 1.5;
    transform.transform.rotation.w = 1.0;
    cloth_sim::Attach attach;
    attach.request.id = id;
    attach.request.frame = frame;
    attach.request.particles = {id + 4};  // gripper 1 holds 4 and 5
    // The transform reaches the node's listener some time after it is sent; the clock stays at `now`.
    const auto deadline = deadlineIn(15.0);
    while (true) {
      broadcaster.sendTransform(transform);
      EXPECT_TRUE(callService(nodeTopic("attach"), attach)) << "~attach does not answer";
      if (attach.response.message.find("unknown frame") == std::string::npos || Clock::now() >= deadline) {
        return attach.response;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  };
  const auto refused = attachStale(3, "late_hand", 0.49);
  EXPECT_FALSE(refused.success) << refused.message;
  EXPECT_NE(refused.message.find("is 0.51 s old at the next frame's end"), std::string::npos) << refused.message;
  const auto taken = attachStale(4, "recent_hand", 0.47);
  EXPECT_TRUE(taken.success) << taken.message;
}

// ---- 9. Bad parameters make the node exit (bad_params.test) ---------------------------------------

namespace {

/// cloth_node sits next to this test binary in devel/lib/cloth_sim.
std::string nodeBinary() {
  char path[4096];
  const ssize_t length = readlink("/proc/self/exe", path, sizeof(path) - 1);
  if (length <= 0) return "cloth_node";
  std::string self(path, static_cast<std::size_t>(length));
  return self.substr(0, self.rfind('/') + 1) + "cloth_node";
}

/// Starts the node with `arguments` (under its own name, so its private parameters are its own) and
/// expects it to exit non-zero by itself, with every one of `expected` in its output.
void expectRefused(const std::string& name, const std::string& arguments, const std::vector<std::string>& expected) {
  constexpr int kTimeoutExit = 124;  // timeout(1): the node was still running
  const ProcessResult result = runProcess("timeout 30 " + nodeBinary() + " __name:=" + name + " " + arguments);
  EXPECT_NE(result.exit_code, 0) << result.output;
  EXPECT_NE(result.exit_code, kTimeoutExit) << "the node ran on with " << arguments << ":\n" << result.output;
  EXPECT_NE(result.exit_code, -1) << "the node did not exit normally:\n" << result.output;
  for (const std::string& text : expected) {
    EXPECT_NE(result.output.find(text), std::string::npos) << "'" << text << "' missing from:\n" << result.output;
  }
}

/// The same with private parameters set on the master first (the command line cannot give lists or maps:
/// roscpp takes `_x:=[a, b]` as a string); they are deleted afterwards.
void expectRefusedWithParameters(const std::string& name, const std::map<std::string, XmlRpc::XmlRpcValue>& parameters,
                                 const std::vector<std::string>& expected) {
  for (const auto& [key, value] : parameters) ros::param::set("/" + name + "/" + key, value);
  expectRefused(name, "", expected);
  ros::param::del("/" + name);
}

}  // namespace

TEST(BadParams, ZeroSubstepsNamesTheParameterAndItsRange) {
  expectRefused("bad_substeps", "_substeps:=0", {"substeps = '0'", "auto", "[1, 10000]"});
}

TEST(BadParams, UnknownIntegratorIsNamed) {
  expectRefused("bad_integrator", "_integrator:=bogus", {"integrator", "bogus", "rk4", "implicit_euler"});
}

TEST(BadParams, AParentFrameThatIsTheFrameItselfIsNamed) {
  expectRefused("bad_parent", "_parent_frame_id:=world", {"parent_frame_id", "'world'", "other than ~frame_id"});
}

TEST(BadParams, ASphereFramePrefixWithALeadingSlashIsNamed) {
  expectRefused("bad_sphere_prefix", "_sphere_frame_prefix:=/sphere_",
                {"sphere_frame_prefix = '/sphere_'", "without a leading '/'"});
}

TEST(BadParams, SolverCapAndThreadsOutsideTheirRangesAreNamed) {
  expectRefused("bad_solver", "_solver_max_iterations:=0", {"solver_max_iterations = 0", "[1, 10000]"});
  expectRefused("bad_threads", "_threads:=0", {"threads = 0", "[1, 64]"});
}

TEST(BadParams, UnknownSceneIsNamed) {
  expectRefused("bad_scene", "_scene:=no_such_scene", {"no_such_scene", "hanging"});
}

TEST(BadParams, ANumberForTheSceneIsRefusedByTypeNotTakenAsTheDefault) {
  // Before, `_scene:=42` silently ran the default scene.
  expectRefused("bad_scene_type", "_scene:=42", {"~scene = 42 (an integer): must be a string"});
}

TEST(BadParams, AListForTheFrameIdIsRefusedByType) {
  XmlRpc::XmlRpcValue list;
  list[0] = std::string("a");
  list[1] = std::string("b");
  expectRefusedWithParameters("bad_frame_type", {{"frame_id", list}}, {"~frame_id = a list of 2: must be a string"});
  expectRefused("bad_mesh_rate_type", "_mesh_rate:=fast", {"~mesh_rate", "must be a number"});
}

TEST(BadParams, ASceneKeyOfTheWrongTypeIsRefusedByName) {
  expectRefused("bad_name_type", "_name:=42", {"name", "expected a string"});
  expectRefused("bad_rows_type", "_rows:=5.5", {"rows", "expected an integer"});
}

TEST(BadParams, ATinyFrameRateIsRefusedByNameInsteadOfAbortingTheNode) {
  // Before, 1e-10 Hz passed validation and ros::Duration aborted the node ("out of dual 32-bit range").
  expectRefused("bad_frame_rate", "_frame_rate:=1e-10", {"frame_rate", "[1, 1000]"});
}

TEST(BadParams, APinMotionTooFastForTheNodeToPublishFinitelyIsRefused) {
  // Before, the curtain at pin_motion_period 1e-300 ran and published kinetic_energy = inf.
  expectRefused("bad_pin_period", "_scene:=curtain _pin_motion_period:=1e-300",
                {"pin_motion_period", "at most 100 m/s"});
}

TEST(BadParams, AClothThatStartsInsideASphereIsRefusedNamingTheSphere) {
  // Before, the node ran at frame 0 for good, logging an ERROR every frame (the scene reset every third).
  XmlRpc::XmlRpcValue sphere;
  sphere["center"][0] = 0.0;
  sphere["center"][1] = 0.0;
  sphere["center"][2] = 1.0;
  sphere["radius"] = 0.1;
  XmlRpc::XmlRpcValue spheres;
  spheres[0] = sphere;
  expectRefusedWithParameters("inside_sphere",
                              {{"scene", XmlRpc::XmlRpcValue(std::string("hanging"))},
                               {"rows", XmlRpc::XmlRpcValue(20)},
                               {"cols", XmlRpc::XmlRpcValue(20)},
                               {"spheres", spheres}},
                              {"the cloth starts inside a collider", "sphere 0 (centre (0, 0, 1) m, radius 0.1 m)"});
}

TEST(BadParams, NanInfAndAbsurdSizesAreNamed) {
  // roscpp reads `nan` and `inf` on the command line as doubles.
  // On a scene of the paper's constants (the default `drape` is a material, which refuses them by name).
  expectRefused("bad_nan", "_scene:=hanging _mass:=nan", {"mass = nan"});
  expectRefused("bad_inf", "_scene:=hanging _structural_stiffness:=inf", {"structural_stiffness = inf"});
  expectRefused("bad_rows", "_rows:=100000", {"rows = 100000", "[2, 512]"});
  XmlRpc::XmlRpcValue wind;
  for (int i = 0; i < 3; ++i) wind[i] = 100.0;  // each component allowed, 173 m/s in all
  expectRefusedWithParameters("bad_wind", {{"wind", wind}}, {"wind", "magnitude"});
}

TEST(BadParams, BadCameraParametersAreNamed) {
  // Issue 16: a zero focal length, a 0 x 0 image, an image over 4096 pixels a side, names given twice.
  XmlRpc::XmlRpcValue cameras;
  cameras[0]["name"] = std::string("front");
  cameras[0]["frame"] = std::string("front_optical");
  cameras[0]["fx"] = 0.0;
  cameras[0]["width"] = 0;
  cameras[0]["height"] = 0;
  cameras[1]["name"] = std::string("front");
  cameras[1]["frame"] = std::string("front_optical");
  cameras[1]["width"] = 5000;
  expectRefusedWithParameters("bad_cameras", {{"cameras", cameras}},
                              {"cameras[0].fx = 0: must be in (0, 1e+06]", "cameras[0].width = 0: must be in [1, 4096]",
                               "cameras[0].height = 0", "cameras[1].width = 5000", "cameras[1].name = 'front'"});
}

TEST(BadParams, ARobotDescriptionThatIsMissingOrNotAUrdfIsNamed) {
  expectRefused("bad_urdf_name", "_robot_description:=no_such_description",
                {"~robot_description = 'no_such_description'", "holds a URDF"});
  // Resolved in the node's namespace: "~junk" is the node's own private parameter.
  expectRefusedWithParameters("bad_urdf_text",
                              {{"robot_description", XmlRpc::XmlRpcValue(std::string("~junk"))},
                               {"junk", XmlRpc::XmlRpcValue(std::string("<robot name='r'><link></robot>"))}},
                              {"/bad_urdf_text/junk", "not a URDF"});
  // Before, a name roscpp's NodeHandle refuses ("~..." there, or a space) ended the node with an exception.
  expectRefused("bad_urdf_param_name", "'_robot_description:=a b'", {"~robot_description = 'a b'", "not a valid"});
}

TEST(BadParams, AUrdfCollisionTheUrdfLibraryDropsOrOneOutOfRangeIsNamedByItsLink) {
  // urdfdom drops a <collision> it cannot read with an ERROR line and reads on: before, the node ran
  // with fewer colliders than the robot has. Each URDF: a root link, a good link and the link 'bad'.
  const auto urdf = [](const std::string& bad_collisions) {
    return "<robot name='r'><link name='base'/>"
           "<link name='good'><collision><geometry><sphere radius='0.05'/></geometry></collision></link>"
           "<link name='bad'>" + bad_collisions + "</link>"
           "<joint name='j1' type='fixed'><parent link='base'/><child link='good'/></joint>"
           "<joint name='j2' type='fixed'><parent link='base'/><child link='bad'/></joint></robot>";
  };
  const std::string sphere = "<collision><geometry><sphere radius='0.05'/></geometry></collision>";
  struct Dropped {
    std::string node, collisions, named;
  };
  for (const Dropped& dropped : std::vector<Dropped>{
           {"bad_urdf_box2", sphere + "<collision><geometry><box size='0.1 0.1'/></geometry></collision>", "'bad' (1 of 2)"},
           {"bad_urdf_cylinder", "<collision><geometry><cylinder radius='0.1'/></geometry></collision>", "'bad' (1 of 1)"},
           {"bad_urdf_no_geometry", "<collision><origin xyz='0 0 0.1'/></collision>", "'bad' (1 of 1)"}}) {
    expectRefusedWithParameters(dropped.node,
                                {{"robot_description", XmlRpc::XmlRpcValue(std::string("~urdf"))},
                                 {"urdf", XmlRpc::XmlRpcValue(urdf(dropped.collisions))}},
                                {"/" + dropped.node + "/urdf", "could not read the <collision> elements of links " + dropped.named});
  }
  // Read, but out of the colliders' ranges: named by link and collision, not by an index into frame_colliders.
  expectRefusedWithParameters(
      "bad_urdf_radius",
      {{"robot_description", XmlRpc::XmlRpcValue(std::string("~urdf"))},
       {"urdf", XmlRpc::XmlRpcValue(urdf(sphere + "<collision><geometry><sphere radius='0'/></geometry></collision>"))}},
      {"URDF link 'bad' collision 1: radius = 0: must be in (0, 100]"});
  // The control: the same robot with two good collisions on 'bad' runs.
  ros::param::set("/good_urdf/robot_description", std::string("~urdf"));
  ros::param::set("/good_urdf/urdf", urdf(sphere + sphere));
  const ProcessResult result = runProcess("timeout 3 " + nodeBinary() + " __name:=good_urdf");
  ros::param::del("/good_urdf");
  EXPECT_EQ(result.exit_code, 124) << result.output;
  EXPECT_NE(result.output.find("3 colliders from the URDF"), std::string::npos) << result.output;
}

TEST(BadParams, AMaterialWithItsOwnConstantsOrAnUnknownPresetIsNamed) {
  // Issue 17: the default scene (drape) is cotton; a mass or spring constant over it is refused by name.
  expectRefused("bad_material_mass", "_mass:=0.3 _bend_stiffness:=5",
                {"material and bend_stiffness, mass given together", "give one or the other"});
  expectRefused("bad_material_name", "_material:=velvet", {"material", "cotton, denim, wool, polyester, silk", "velvet"});
  expectRefused("bad_bend_model", "_scene:=hanging _bend_model:=curvature", {"bend_model = curvature: needs a material"});
  // A material given as a parameter replaces a paper scene's constants: the node runs.
  const ProcessResult result = runProcess("timeout 3 " + nodeBinary() +
                                          " __name:=good_material _scene:=hanging _material:=denim _bend_model:=curvature");
  EXPECT_EQ(result.exit_code, 124) << result.output;
}

TEST(BadParams, GoodParametersRun) {
  // Control for the three above: with valid parameters the same command is still running at the timeout.
  const ProcessResult result =
      runProcess("timeout 3 " + nodeBinary() + " __name:=good_params _substeps:=20 _rows:=5 _cols:=5");
  EXPECT_EQ(result.exit_code, 124) << result.output;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "cloth_node_tests");
  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return result;
}
