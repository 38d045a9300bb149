#include "cloth_sim/ros/cloth_node.h"

#include "cloth_sim/core/constants.h"
#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/state_file.h"
#include "cloth_sim/io/texture.h"
#include "cloth_sim/ros/conversions.h"
#include "cloth_sim/ros/ros_time.h"
#include "cloth_sim/ros/shutdown.h"

#include <boost/make_shared.hpp>
#include <ros/names.h>
#include <ros/package.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace cloth_sim {

namespace {

/// Private parameters that belong to the node rather than to the scene.
const std::set<std::string>& nodeOnlyParameters() {
  static const std::set<std::string> names{Names::kSceneParam, Names::kFrameIdParam, Names::kMeshRateParam,
                                           Names::kParentFrameParam, Names::kSphereFramePrefixParam,
                                           Names::kTuningNamespace, Names::kRobotDescriptionParam};
  return names;
}

std::string join(const std::vector<std::string>& parts, const std::string& separator) {
  std::string joined;
  for (const std::string& part : parts) joined += (joined.empty() ? "" : separator) + part;
  return joined;
}

/// Timer jitter: a frame counts as due this much before its exact time, in frames.
constexpr double kFrameDueTolerance = 1e-6;
constexpr double kWarnThrottle_s = 5.0;
/// The scene when ~scene is not given: a cloth that sags and folds between two hooks.
constexpr const char* kDefaultScene = "drape";
/// A mesh counts as due this fraction of a frame before its due time (timer ticks jitter).
constexpr double kMeshEarlyFrames = 0.5;
using core::kMillisecondsPerSecond;

/// What a reset or a load let go, as ~reset answers it ("; released grasp ids 3, 7; detached gripper ids
/// 1"; "" for nothing): their clients must grasp or attach again.
std::string letGoText(const std::vector<core::Grasp>& grasps, const std::vector<core::Gripper>& grippers) {
  const std::string grasp_ids = core::idList(grasps);
  const std::string gripper_ids = core::idList(grippers);
  return (grasp_ids.empty() ? "" : "; released grasp ids " + grasp_ids) +
         (gripper_ids.empty() ? "" : "; detached gripper ids " + gripper_ids);
}

}  // namespace

ClothNode::ClothNode(const ros::NodeHandle& node_handle, const ros::NodeHandle& private_handle)
    : nh_(node_handle), pnh_(private_handle) {}

bool ClothNode::start(std::string* error) {
  // The whole private namespace, read once: each node parameter's type is checked by optionalParameter,
  // each scene key's by the scene-file reader (buildSimulation), so no wrong type falls back silently.
  XmlRpc::XmlRpcValue parameters = parameterTree(pnh_.getNamespace());
  std::string parent_frame;
  std::string robot_description;
  std::string scene = kDefaultScene;
  double mesh_rate_hz = 0.0;  // not given: the frame rate, known once the scene is built
  if (!optionalParameter(parameters, Names::kFrameIdParam, &frame_id_, error) ||
      !optionalParameter(parameters, Names::kParentFrameParam, &parent_frame, error) ||
      !optionalParameter(parameters, Names::kSphereFramePrefixParam, &sphere_frame_prefix_, error) ||
      !optionalParameter(parameters, Names::kSceneParam, &scene, error) ||
      !optionalParameter(parameters, Names::kMeshRateParam, &mesh_rate_hz, error) ||
      !optionalParameter(parameters, Names::kRobotDescriptionParam, &robot_description, error)) {
    return false;
  }
  if (!robot_description.empty()) {
    // Resolved as a graph name in the node's namespace ("~name": the node's own), as robot_state_publisher
    // resolves its robot_description; an invalid name is refused, not thrown.
    std::string resolved;
    try {
      resolved = ros::names::resolve(robot_description);
    } catch (const ros::InvalidNameException& e) {
      *error = "parameter ~robot_description = '" + robot_description + "': not a valid parameter name (" + e.what() + ")";
      return false;
    }
    std::string urdf_xml;
    if (!ros::param::get(resolved, urdf_xml)) {
      *error = "parameter ~robot_description = '" + robot_description + "': no string parameter " + resolved +
               " holds a URDF";
      return false;
    }
    std::vector<std::string> mesh_links;
    std::string why;
    if (!collidersFromUrdf(urdf_xml, &urdf_colliders_, &mesh_links, &why)) {
      *error = "parameter " + resolved + ": " + why;
      return false;
    }
    if (!mesh_links.empty()) {
      ROS_WARN("cloth_node: %s: skipping the mesh collisions of links %s (only spheres, cylinders and boxes collide)",
               resolved.c_str(), join(mesh_links, ", ").c_str());
    }
    ROS_INFO("cloth_node: %zu colliders from the URDF in %s", urdf_colliders_.size(), resolved.c_str());
  }
  for (const auto& [name, value] : {std::pair<const char*, const std::string*>{Names::kFrameIdParam, &frame_id_},
                                    {Names::kParentFrameParam, &parent_frame},
                                    {Names::kSphereFramePrefixParam, &sphere_frame_prefix_},
                                    {Names::kSceneParam, &scene}}) {
    const std::string problem = core::textLengthProblem(std::string("parameter ~") + name, *value);
    if (!problem.empty()) {
      *error = problem;
      return false;
    }
  }
  if (frame_id_.empty() || frame_id_[0] == '/') {
    *error = "parameter ~frame_id = '" + frame_id_ + "': must be a non-empty tf frame name without a leading '/'";
    return false;
  }
  if (!parent_frame.empty() && (parent_frame[0] == '/' || parent_frame == frame_id_)) {
    *error = "parameter ~parent_frame_id = '" + parent_frame +
             "': must be a tf frame name without a leading '/', other than ~frame_id";
    return false;
  }
  if (sphere_frame_prefix_.empty() || sphere_frame_prefix_[0] == '/') {
    *error = "parameter ~sphere_frame_prefix = '" + sphere_frame_prefix_ +
             "': must be the non-empty start of a tf frame name, without a leading '/'";
    return false;
  }
  scenes_dir_ = ros::package::getPath("cloth_sim") + "/config/scenes";
  std::unique_ptr<core::Simulation> simulation = buildSimulation(scene, &parameters, error);
  if (!simulation) return false;
  simulation_ = std::move(simulation);
  // The mesh is the heavy message (each vertex six times, with colours): a viewer may want it less often.
  const bool mesh_rate_given =
      parameters.getType() == XmlRpc::XmlRpcValue::TypeStruct && parameters.hasMember(Names::kMeshRateParam);
  if (mesh_rate_given) mesh_rate_given_hz_ = mesh_rate_hz;
  mesh_rate_hz = meshRate_hz();
  if (!std::isfinite(mesh_rate_hz) || mesh_rate_hz <= 0.0 || mesh_rate_hz > core::OptionLimits::kMaxFrameRateHz) {
    *error = "parameter ~mesh_rate = " + std::to_string(mesh_rate_hz) + ": must be in (0, " +
             std::to_string(core::OptionLimits::kMaxFrameRateHz) + "] Hz";
    return false;
  }
  mesh_schedule_ = std::make_unique<MeshSchedule>(mesh_rate_hz);

  mesh_pub_ = pnh_.advertise<visualization_msgs::Marker>(Names::kMeshTopic, kMarkerQueue);
  state_pub_ = pnh_.advertise<cloth_sim::ClothState>(Names::kStateTopic, kStateQueue);
  colliders_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>(Names::kCollidersTopic, kMarkerQueue);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);
  cameras_ = std::make_unique<DepthCameras>(pnh_, tf_buffer_, frame_id_, simulation_->options().cameras);
  wind_sub_ = pnh_.subscribe(Names::kWindTopic, kWindQueue, &ClothNode::onWind, this);
  ros::SubscribeOptions grasp_options = ros::SubscribeOptions::create<cloth_sim::Grasp>(
      Names::kGraspTopic, kGraspSubscriberQueue,
      [this](const cloth_sim::Grasp::ConstPtr& message) { onGraspReceived(message); }, ros::VoidConstPtr(),
      &grasp_receive_queue_);
  grasp_sub_ = pnh_.subscribe(grasp_options);
  grasp_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &grasp_receive_queue_);
  grasp_spinner_->start();
  grippers_ = std::make_unique<Grippers>(
      pnh_, frame_inputs_, frame_id_, [this]() -> core::Simulation& { return *simulation_; },
      [this]() { return frameTime(simulation_->state().frame + 1); });
  frame_colliders_ = std::make_unique<FrameColliderInputs>(frame_inputs_, frame_id_,
                                                           [this]() -> core::Simulation& { return *simulation_; });
  // The mouse's commands join ~grasp's queue, so they are applied in order with the topic's.
  mouse_ = std::make_unique<MouseDrag>(pnh_.resolveName(Names::kMouseNamespace), [this](const cloth_sim::Grasp& grasp) {
    onGraspReceived(boost::make_shared<const cloth_sim::Grasp>(grasp));
  }, [this](const std_msgs::Header& header, const Eigen::Vector3d& point_m) {
    geometry_msgs::PointStamped point;
    point.header = header;
    point.point = toPoint(point_m);
    geometry_msgs::PointStamped in_frame;
    std::string why;
    if (!frame_inputs_.express(point, frame_id_, &in_frame, &why)) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped a mouse-down in frame '%s': %s",
                        header.frame_id.c_str(), why.c_str());
      return -1;
    }
    return simulation_->nearestParticle(Eigen::Vector3d(in_frame.point.x, in_frame.point.y, in_frame.point.z));
  });
  reset_srv_ = pnh_.advertiseService(Names::kResetService, &ClothNode::onReset, this);
  pause_srv_ = pnh_.advertiseService(Names::kPauseService, &ClothNode::onPause, this);
  // ~step waits for its frames on a thread of its own, so the spin thread stays free to run them in chunks
  // between the other callbacks (and to notice a shutdown).
  ros::AdvertiseServiceOptions step_options;
  step_options.init<cloth_sim::Step>(Names::kStepService, [this](cloth_sim::Step::Request& request,
                                                                 cloth_sim::Step::Response& response) {
    return onStep(request, response);
  });
  step_options.callback_queue = &step_queue_;
  step_srv_ = pnh_.advertiseService(step_options);
  step_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &step_queue_);
  step_spinner_->start();
  load_scene_srv_ = pnh_.advertiseService(Names::kLoadSceneService, &ClothNode::onLoadScene, this);
  save_state_srv_ = pnh_.advertiseService(Names::kSaveStateService, &ClothNode::onSaveState, this);
  load_state_srv_ = pnh_.advertiseService(Names::kLoadStateService, &ClothNode::onLoadState, this);

  // In its own namespace: dynamic_reconfigure leaves its values on the parameter server, where the next
  // start-up would otherwise read them as overrides of the next scene.
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<cloth_sim::ClothConfig>>(
      reconfigure_mutex_, ros::NodeHandle(pnh_, Names::kTuningNamespace));
  publishReconfigureRanges();
  pushConfig();  // before the callback, so its first call carries the scene's values, not the .cfg defaults
  reconfigure_->setCallback([this](cloth_sim::ClothConfig& config, std::uint32_t level) { onReconfigure(config, level); });

  diagnostics_.setHardwareID("cloth_sim");
  diagnostics_.add("simulation", this, &ClothNode::diagnose);
  diagnostics_.add("cameras", cameras_.get(), &DepthCameras::diagnose);
  diagnostics_.add("grippers", grippers_.get(), &Grippers::diagnose);
  diagnostics_.add("frame colliders", frame_colliders_.get(), &FrameColliderInputs::diagnose);
  window_start_ = std::chrono::steady_clock::now();

  if (!parent_frame.empty()) {
    static_broadcaster_.sendTransform(identityTransform(parent_frame, frame_id_, ros::Time::now()));
  }

  timer_ = pnh_.createTimer(ros::Duration(simulation_->options().frameDuration_s()), &ClothNode::onTimer, this);
  signal_timer_ = pnh_.createWallTimer(ros::WallDuration(kSignalPoll_s), &ClothNode::onSignalPoll, this);
  if (ros::Time::isSimTime()) {
    clock_watch_timer_ = pnh_.createWallTimer(ros::WallDuration(kClockWatch_s), &ClothNode::onClockWatch, this);
  }
  const std::string substeps = simulation_->options().autoSubsteps() ? std::string(core::kAutoSubstepsName)
                                                                      : std::to_string(simulation_->options().substeps);
  ROS_INFO("cloth_node: scene '%s', %dx%d particles, %s with %s substeps, %.0f Hz, frame '%s'",
           simulation_->options().name.c_str(), simulation_->grid().rows, simulation_->grid().cols,
           core::integratorName(simulation_->options().integrator), substeps.c_str(),
           simulation_->options().frame_rate_hz, frame_id_.c_str());
  return true;
}

ClothNode::~ClothNode() {
  {
    std::lock_guard<std::mutex> lock(step_mutex_);
    step_stopping_ = true;
  }
  step_done_.notify_all();
  if (step_spinner_) step_spinner_->stop();
  if (grasp_spinner_) grasp_spinner_->stop();
  pnh_.getCallbackQueue()->removeByID(reinterpret_cast<std::uint64_t>(this));
}

std::unique_ptr<core::Simulation> ClothNode::buildSimulation(const std::string& scene,
                                                             const XmlRpc::XmlRpcValue* parameters,
                                                             std::string* error) const {
  const std::string path = core::resolveScenePath(scene, scenes_dir_);
  core::SceneOptions options;
  std::vector<std::string> errors;
  if (!core::loadSceneFile(path, &options, &errors)) {
    *error = "scene '" + scene + "': " + join(errors, "; ") + " (built-in scenes: " +
             join(core::builtinSceneNames(scenes_dir_), ", ") + ")";
    return nullptr;
  }
  if (parameters && parameters->getType() == XmlRpc::XmlRpcValue::TypeStruct) {
    YAML::Node overlay(YAML::NodeType::Map);
    const std::vector<std::string>& keys = core::sceneKeys();
    for (const auto& entry : *parameters) {
      if (nodeOnlyParameters().count(entry.first)) continue;
      if (std::find(keys.begin(), keys.end(), entry.first) == keys.end()) {
        ROS_WARN("cloth_node: ignoring parameter ~%s: not a scene key (see the README's parameter table)",
                 entry.first.c_str());
        continue;
      }
      overlay[entry.first] = toYaml(entry.second);
    }
    if (!core::applySceneYaml(overlay, "parameter", &options, &errors)) {
      *error = join(errors, "; ");
      return nullptr;
    }
    const std::vector<std::string> problems = core::validateSceneOptions(options);
    if (!problems.empty()) {
      *error = "invalid parameter: " + join(problems, "; ");
      return nullptr;
    }
  }
  if (!urdf_colliders_.empty()) {
    // The robot's links touch every scene it loads.
    options.colliders.frames.insert(options.colliders.frames.end(), urdf_colliders_.begin(), urdf_colliders_.end());
    const std::vector<std::string> problems = core::validateSceneOptions(options);
    if (!problems.empty()) {
      *error = "scene '" + scene + "' with the URDF's colliders: " + join(problems, "; ");
      return nullptr;
    }
  }
  std::unique_ptr<core::Simulation> simulation;
  try {
    simulation = std::make_unique<core::Simulation>(options);
  } catch (const std::exception& e) {  // a cloth that starts inside a collider; memory may run out
    *error = "scene '" + scene + "': cannot be built: " + e.what();
    return nullptr;
  }
  Eigen::Matrix3Xf colors;
  std::string texture_error;
  if (!core::sceneVertexColors(options.texture, simulation->grid().uv, &colors, &texture_error)) {
    *error = "scene '" + scene + "': " + texture_error;
    return nullptr;
  }
  simulation->setVertexColors(colors);
  return simulation;
}

void ClothNode::install(std::unique_ptr<core::Simulation> simulation) {
  // Everything that can throw comes before the swap (ros::Duration throws beyond 2^31 s; the validated
  // frame rate keeps it far inside), so a failure leaves the running scene in place.
  const ros::Duration frame_period(simulation->options().frameDuration_s());
  cancelStep("the scene was replaced");
  simulation_ = std::move(simulation);
  if (grippers_) grippers_->synchronize();  // a new scene holds nothing
  if (mouse_) mouse_->endDrag();  // nor the mouse: its drag's grasp went with the old scene
  step_cost_ms_ = 0.0;  // the old scene's cost says nothing about this one's
  timer_.setPeriod(frame_period);
  mesh_schedule_ = std::make_unique<MeshSchedule>(meshRate_hz());  // the new scene's frame rate, if that is it
  last_report_ = core::FrameReport();
  asleep_ = false;
  forgetPublished();  // the new scene goes out at the next publish
  reanchor();
  pushConfig();
}

void ClothNode::reanchor() {
  anchor_time_ = ros::Time::now();
  anchor_frame_ = simulation_->state().frame;
  // Under use_sim_time the clock reads zero until the first /clock message: anchor on that one instead.
  anchored_ = !anchor_time_.isZero();
}

void ClothNode::onTimer(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  if (anchored_ && now < last_tick_) {
    // /clock went backwards (a looping bag, a simulator reset): start counting frames from here.
    ROS_WARN("cloth_node: time jumped back from %.3f s to %.3f s; frames are counted from now", last_tick_.toSec(),
             now.toSec());
    reanchor();
  }
  last_tick_ = now;
  if (!anchored_) reanchor();
  if (anchored_ && !paused_) {
    const double elapsed_frames =
        std::max(0.0, secondsBetween(anchor_time_, now) * simulation_->options().frame_rate_hz);
    const auto due = anchor_frame_ + static_cast<std::uint64_t>(std::floor(elapsed_frames + kFrameDueTolerance));
    std::int64_t behind = static_cast<std::int64_t>(due) - static_cast<std::int64_t>(simulation_->state().frame);
    // In wall time a slow machine must not snowball; under /clock every frame is owed (determinism),
    // unless the clock leaps far ahead (a bag's first stamp after zero), which would stall the node.
    const std::int64_t most = ros::Time::isSimTime() ? kMaxSimTimeCatchUpFrames : kMaxCatchUpFrames;
    if (behind > most) {
      if (ros::Time::isSimTime()) {
        ROS_WARN("cloth_node: /clock leapt %lld frames ahead; simulating %lld and counting from there",
                 static_cast<long long>(behind), static_cast<long long>(most));
      }
      dropped_frames_ += behind - most;
      advanceFrames(static_cast<int>(most), true);
      reanchor();
    } else if (behind > 0 && !advanceFrames(static_cast<int>(behind), true)) {
      reanchor();  // a frame was rolled back: owe nothing, try again at the next tick
    }
  }
  // While paused, ~state repeats every tick (monitors and rviz keep seeing the cloth); while running it
  // comes once per frame.
  publish(now, paused_ || last_state_frame_ != simulation_->state().frame);
  diagnostics_.update();
}

bool ClothNode::advanceFrames(int frames, bool publish_between) {
  for (int k = 0; k < frames && ros::ok(); ++k) {  // a shutdown does not wait for the frames owed
    // The frame before this one was computed to catch up: it goes out now, not folded into the tick's.
    if (publish_between && k > 0) publishState(frameTime(simulation_->state().frame));
    const auto start = std::chrono::steady_clock::now();
    const bool gripped = !simulation_->grippers().empty();
    if (gripped) grippers_->beforeFrame(frameTime(simulation_->state().frame + 1));
    if (!simulation_->options().colliders.frames.empty()) frame_colliders_->beforeFrame(frameTime(simulation_->state().frame + 1));
    const core::FrameReport report = simulation_->advanceFrame();
    // A recovery that reset the scene starts the frame count again: frames are counted from now, as after
    // ~reset (else the frames after it were stamped seconds before it), and the frames the tick still owed
    // are owed no more.
    if (report.scene_reset) reanchor();
    // Asleep through the frame a sleeping cloth computes once a second to check on itself, if it found the
    // cloth at rest (report.asleep alone is false there, and under /clock the 1 Hz report can fall on it
    // every time: a cloth asleep for minutes never read as asleep).
    asleep_ = report.sleeping;
    // A frame the cloth slept through computed nothing: the diagnostics keep the figures (substeps,
    // iterations, contacts) of the last frame that was computed, whose state the cloth still is.
    if (!report.asleep) last_report_ = report;
    if (report.scene_reset && mouse_) mouse_->endDrag();  // a recovery's reset let the mouse's grasp go
    if (gripped) {
      if (report.scene_reset) grippers_->synchronize();  // and every gripper
      grippers_->afterFrame(frameTime(simulation_->state().frame));
    }
    step_cost_ms_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() * kMillisecondsPerSecond;
    frame_budget_.addFrame(step_cost_ms_);
    if (!report.recovery.empty()) {
      // Not throttled: it happens once per failing setting, and the user must see what was changed.
      ROS_ERROR("cloth_node: recovered by itself: %s", report.recovery.c_str());
      recovery_ = report.recovery;
      pushConfig();  // the integrator and substeps may have changed: the sliders show what runs
    } else if (!report.reason.empty()) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: %s", report.reason.c_str());
    }
    if (!report.stable) {
      ++unstable_frames_;
      return false;  // the same frame would diverge again right away: leave it to the next tick
    }
    window_sim_s_ += simulation_->options().frameDuration_s();
    if (report.scene_reset) break;
  }
  return true;
}

void ClothNode::publishState(const ros::Time& stamp) {
  frame_budget_.addStateMessage();
  last_state_frame_ = simulation_->state().frame;
  if (state_pub_.getNumSubscribers() == 0) return;
  const cloth_sim::ClothState state = toStateMessage(*simulation_, frame_id_, stamp);
  const std::vector<std::string> non_finite = nonFiniteFields(state);
  if (non_finite.empty()) {
    state_pub_.publish(state);
  } else {
    ROS_ERROR_THROTTLE(kWarnThrottle_s, "cloth_node: not publishing ~state: %s not finite",
                       join(non_finite, ", ").c_str());
  }
}

ros::Time ClothNode::frameTime(std::uint64_t frame) const {
  if (!anchored_) return ros::Time::now();
  const double since_anchor_s =
      (static_cast<double>(frame) - static_cast<double>(anchor_frame_)) / simulation_->options().frame_rate_hz;
  return anchor_time_ + ros::Duration(since_anchor_s);
}

double ClothNode::meshRate_hz() const {
  return mesh_rate_given_hz_ ? *mesh_rate_given_hz_ : simulation_->options().frame_rate_hz;
}

void ClothNode::forgetPublished() {
  colliders_to_clear_ = true;
  last_published_stamp_.reset();
  mesh_schedule_->restart();
}

void ClothNode::publish(const ros::Time& stamp, bool with_state) {
  // The core rolls a diverged frame back, so this holds; rviz crashes on NaN markers, so check anyway.
  if (!core::isFiniteAndBounded(simulation_->state(), core::Simulation::kDivergenceBound_m)) {
    ROS_ERROR_THROTTLE(kWarnThrottle_s, "cloth_node: state is not finite; not publishing");
    return;
  }
  // Once per stamp and frame: under /use_sim_time roscpp fires a late timer again with no new time when
  // /clock leaps, and what follows went out twice at one stamp (the spheres' tf then made every tf
  // listener, the node's own too, log TF_REPEATED_DATA). But a new frame at the same stamp (a ~step, a
  // reset or a loaded state under a held /clock) is news: it goes out, all but the tf, which tf2 would
  // refuse at a stamp it has. A replaced scene or state, and a reset, clear what was sent.
  const std::uint64_t frame = simulation_->state().frame;
  const bool new_stamp = last_published_stamp_ != stamp;
  const bool new_frame = frame != last_published_frame_;  // an empty stamp makes new_stamp true anyway
  if (!new_stamp && new_frame) mesh_schedule_->restart();
  // Half a frame early counts as on time (timer jitter); time running backwards (a looping /clock) makes
  // a mesh due at once (MeshSchedule).
  if ((new_stamp || new_frame) && mesh_pub_.getNumSubscribers() > 0 &&
      mesh_schedule_->due(stamp.toSec(), kMeshEarlyFrames * simulation_->options().frameDuration_s())) {
    mesh_pub_.publish(toMeshMarker(*simulation_, frame_id_, stamp));
  }
  if (with_state) publishState(stamp);
  if (!new_stamp && !new_frame) return;
  last_published_stamp_ = stamp;
  last_published_frame_ = frame;
  // The first array after the scene was replaced, reset or restored begins with a DELETEALL that takes the
  // old scene's shapes off the displays; for a scene without colliders it is the only one sent.
  const bool has_colliders = !simulation_->options().colliders.empty();
  if (colliders_pub_.getNumSubscribers() > 0 && (has_colliders || colliders_to_clear_)) {
    colliders_pub_.publish(toColliderMarkers(*simulation_, frame_id_, stamp, colliders_to_clear_));
    colliders_to_clear_ = false;
  }
  if (new_stamp) {
    const auto transforms = toSphereTransforms(*simulation_, frame_id_, stamp, sphere_frame_prefix_);
    if (!transforms.empty()) tf_broadcaster_.sendTransform(transforms);
  }
  cameras_->publish(*simulation_, stamp);  // ~points and the cameras, each only while subscribed
  if (mouse_) mouse_->update(*simulation_, frame_id_, stamp);
}

void ClothNode::onWind(const geometry_msgs::Vector3Stamped::ConstPtr& message) {
  geometry_msgs::Vector3Stamped wind = *message;
  const Eigen::Vector3d raw(wind.vector.x, wind.vector.y, wind.vector.z);
  const std::string problem = core::windVelocityProblem(raw);
  if (!problem.empty()) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~wind (%g, %g, %g) m/s: %s", raw.x(), raw.y(), raw.z(),
                      problem.c_str());
    return;
  }
  std::string why;
  if (!frame_inputs_.express(*message, frame_id_, &wind, &why)) {  // a free vector: rotation only
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~wind in frame '%s': %s",
                      message->header.frame_id.c_str(), why.c_str());
    return;
  }
  simulation_->setWindVelocity(Eigen::Vector3d(wind.vector.x, wind.vector.y, wind.vector.z));
}

/// Applies the filed ~grasp commands on the node's callback queue (the spin thread).
class ClothNode::GraspDrain : public ros::CallbackInterface {
 public:
  explicit GraspDrain(ClothNode* node) : node_(node) {}
  CallResult call() override {
    node_->applyPendingGrasps();
    return Success;
  }

 private:
  ClothNode* node_;
};

void ClothNode::onGraspReceived(const cloth_sim::Grasp::ConstPtr& message) {
  // A drain is queued when the first command arrives; later ones join it until it runs.
  if (grasp_commands_.push(message)) {
    pnh_.getCallbackQueue()->addCallback(boost::make_shared<GraspDrain>(this), reinterpret_cast<std::uint64_t>(this));
  }
}

void ClothNode::applyPendingGrasps() {
  for (const cloth_sim::Grasp::ConstPtr& command : grasp_commands_.take()) applyGrasp(command);
  const std::size_t dropped = grasp_commands_.takeDropped();
  if (dropped > 0) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped %zu ~grasp commands: more than %zu ids pending at once",
                      dropped, GraspCommandQueue::kMaxPendingIds);
  }
}

void ClothNode::onSignalPoll(const ros::WallTimerEvent&) {
  if (shutdown_begun_ || !shutdownSignalled()) return;
  shutdown_begun_ = true;
  cancelStep("the node is shutting down (" + shutdownSignalName() + ")");
  // Behind the step service's callback on its single thread: it runs once that callback has returned,
  // and roscpp writes a service's answer before its callback returns to the queue.
  step_queue_.addCallback(boost::make_shared<ShutdownRequest>(), reinterpret_cast<std::uint64_t>(this));
}

void ClothNode::onClockWatch(const ros::WallTimerEvent&) {
  // roscpp's timer thread does not always notice /clock going backwards, and then the frame timer does not
  // fire for a while (measured: /clock sent back 5 s from 100.5 after leaps of five frames, then on in
  // 0.02 s steps, and no frame, ~state or warning for 25 of them in 2 of 3 runs). Re-armed, it fires one
  // frame after the new time, and onTimer counts frames from there.
  // The clock behind the last tick means it went back and the timer has not fired since (a jump the clock
  // overtakes again before the timer's next due time needs nothing). Re-armed once per such tick: re-arming
  // at every look would put the tick off for good behind a clock that advances less than a frame a look.
  const ros::Time now = ros::Time::now();
  if (anchored_ && now < last_tick_ && rearmed_after_tick_ != last_tick_) {
    timer_.setPeriod(ros::Duration(simulation_->options().frameDuration_s()), true);
    rearmed_after_tick_ = last_tick_;
  }
}

void ClothNode::applyGrasp(const cloth_sim::Grasp::ConstPtr& message) {
  if (message->action == cloth_sim::Grasp::RELEASE) {
    if (!simulation_->release(message->id)) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp RELEASE: no grasp with id %u", message->id);
    }
    return;
  }
  if (message->action != cloth_sim::Grasp::GRAB) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp: action %u is neither GRAB (0) nor RELEASE (1)",
                      message->action);
    return;
  }
  geometry_msgs::PointStamped target;
  target.header = message->header;
  target.point = message->target;
  const Eigen::Vector3d raw(target.point.x, target.point.y, target.point.z);
  if (!raw.allFinite()) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp id %u: target is not finite", message->id);
    return;
  }
  // The force in header.frame_id too: a free vector, rotated only (as ~wind's), by the target's transform.
  geometry_msgs::Vector3Stamped force;
  force.header = message->header;
  force.vector = message->force;
  geometry_msgs::PointStamped in_frame;
  geometry_msgs::Vector3Stamped force_in_frame;
  std::string why;
  if (!frame_inputs_.express(target, force, frame_id_, &in_frame, &force_in_frame, &why)) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp id %u in frame '%s': %s", message->id,
                      message->header.frame_id.c_str(), why.c_str());
    return;
  }
  std::string error;
  const core::GraspRequest request =
      toGraspRequest(*message, Eigen::Vector3d(in_frame.point.x, in_frame.point.y, in_frame.point.z),
                     Eigen::Vector3d(force_in_frame.vector.x, force_in_frame.vector.y, force_in_frame.vector.z));
  if (!simulation_->grab(request, &error)) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp id %u: %s", message->id, error.c_str());
  }
}

bool ClothNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  cancelStep("~reset restarted the scene");
  // ~grasp and mouse commands received before the request apply before it (a drag's update waiting in the
  // queue would otherwise grab again after the reset ended the drag).
  applyPendingGrasps();
  // The grasps and grippers the reset lets go: their clients must grasp or attach again.
  const std::string let_go = letGoText(simulation_->grasps(), simulation_->grippers());
  simulation_->reset();
  last_report_ = core::FrameReport();  // no frame since: the diagnostics read 0 substeps and iterations
  asleep_ = false;  // frame 0 is computed, not slept through
  grippers_->synchronize();  // a reset lets every gripper go
  if (mouse_) mouse_->endDrag();  // and the mouse's grasp: the rest of its drag grabs nothing
  forgetPublished();  // the cloth back at its start goes out whatever the clock reads
  reanchor();
  publish(ros::Time::now());
  response.success = true;
  response.message = "scene '" + simulation_->options().name + "' back at frame 0" + let_go;
  return true;
}

bool ClothNode::onPause(std_srvs::SetBool::Request& request, std_srvs::SetBool::Response& response) {
  response.success = true;
  if (request.data == paused_) {
    // Idempotent: re-anchoring here would restart the frame clock, and a client repeating ~pause false
    // faster than the frame rate would hold the cloth still.
    response.message = paused_ ? "already paused at frame " + std::to_string(simulation_->state().frame)
                               : "already running";
    return true;
  }
  paused_ = request.data;
  if (!paused_) cancelStep("~pause false resumed real time");
  reanchor();
  response.message = paused_ ? "paused at frame " + std::to_string(simulation_->state().frame) : "running";
  return true;
}

bool ClothNode::onLoadScene(cloth_sim::LoadScene::Request& request, cloth_sim::LoadScene::Response& response) {
  applyPendingGrasps();  // commands received before the request apply to the scene they were sent to
  // All or nothing: the new scene is read, validated, built and textured completely before it replaces
  // the running one; any failure answers with the reason and the old scene carries on.
  std::string error = core::textLengthProblem("scene", request.scene);
  const std::string let_go = letGoText(simulation_->grasps(), simulation_->grippers());  // all, if it loads
  std::unique_ptr<core::Simulation> simulation;
  try {
    if (error.empty()) simulation = buildSimulation(request.scene, nullptr, &error);  // the scene alone
    if (simulation) install(std::move(simulation));
  } catch (const std::exception& e) {  // nothing was swapped: install throws only before its swap
    error = "scene '" + request.scene + "': " + e.what();
  }
  if (!error.empty()) {
    response.success = false;
    response.message = error + "; the current scene keeps running";
    return true;
  }
  response.success = true;
  std::ostringstream message;
  message << "loaded scene '" << simulation_->options().name << "' (" << simulation_->grid().rows << "x"
          << simulation_->grid().cols << ")" << let_go;
  response.message = message.str();
  ROS_INFO("cloth_node: %s", response.message.c_str());
  return true;
}

void ClothNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const auto now = std::chrono::steady_clock::now();
  const double window_wall_s = std::chrono::duration<double>(now - window_start_).count();
  const double real_time_factor = window_wall_s > 0.0 ? window_sim_s_ / window_wall_s : 0.0;
  const core::EnergyReport energy = simulation_->energies();
  const FrameBudget::Verdict budget = frame_budget_.judge(simulation_->options().frameDuration_s(), window_wall_s);
  std::string problem;
  if (!recovery_.empty()) {
    problem = "recovered by itself: " + recovery_;
  } else if (unstable_frames_ > 0) {
    problem = std::to_string(unstable_frames_) + " frames diverged and were rolled back: " + last_report_.reason;
  } else if (!last_report_.reason.empty()) {
    problem = last_report_.reason;
  } else if (budget.over_budget) {
    problem = budget.message + (dropped_frames_ > 0 ? "; " + std::to_string(dropped_frames_) + " frames dropped" : "");
  } else if (dropped_frames_ > 0) {
    problem = std::to_string(dropped_frames_) + " frames dropped: the machine cannot keep up in real time";
  }
  if (problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK,
                   paused_ ? "paused" : asleep_ ? "running; asleep: the cloth is at rest and nothing moves it" : "running");
  } else if (!recovery_.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::ERROR, problem);
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problem);
  }
  status.add("scene", simulation_->options().name);
  status.add("frame", simulation_->state().frame);
  std::vector<std::string> non_finite;  // never published as numbers: rviz and monitors choke on them
  addFiniteValue(status, "sim time [s]", simulation_->state().time_s, &non_finite);
  addFiniteValue(status, "step cost [ms]", step_cost_ms_, &non_finite);
  addFiniteValue(status, "real-time factor", real_time_factor, &non_finite);
  addFiniteValue(status, "mean step cost [ms]", budget.mean_step_cost_ms, &non_finite);
  addFiniteValue(status, "frame budget [ms]", budget.budget_ms, &non_finite);
  addFiniteValue(status, "state rate [Hz]", budget.state_rate_hz, &non_finite);
  addFiniteValue(status, "kinetic energy [J]", energy.kinetic_J, &non_finite);
  addFiniteValue(status, "potential energy [J]", energy.potential_J, &non_finite);
  addFiniteValue(status, "max strain", simulation_->maxStructuralStrain(), &non_finite);
  status.add("integrator", core::integratorName(simulation_->options().integrator));
  status.add("substeps", simulation_->options().autoSubsteps() ? std::string(core::kAutoSubstepsName)
                                                                : std::to_string(simulation_->options().substeps));
  status.add("substeps used", last_report_.substeps_used);
  // The first computation's step over the integrator's largest stable step (0 for implicit Euler): above
  // 1 a fixed substep count is past the stability limit, near 1 it is close to it.
  status.add("stability margin", last_report_.stability_margin);
  status.add("largest stable step [s]", std::isinf(last_report_.stable_step_s) ? std::string("unlimited")
                                                                              : std::to_string(last_report_.stable_step_s));
  // implicit_euler's linear solve in the last frame: iterations per step, and whether it met its tolerance.
  const int steps = std::max(last_report_.substeps_used, 1);
  status.add("solver iterations per step", static_cast<double>(last_report_.steps.solver_iterations) / steps);
  status.add("solver converged", last_report_.steps.converged);
  status.add("paused", paused_);
  // sleep_speed: the last frame was not computed (the figures above are the last computed frame's).
  status.add("asleep", asleep_);
  if (simulation_->options().self_collision.enabled) {
    // The last frame's self-contacts: pairs pushed apart, particles the fail-safe stopped, pairs a pin or
    // gripper dragged through, and triangle pairs that crossed (the frame's warning names those).
    const core::SelfCollisionStats& self = last_report_.self_collision;
    status.add("self-collision contacts", self.contacts);
    status.add("self-collision stopped particles", self.frozen);
    status.add("self-collision forced pairs", self.forced);
    // Triangle pairs that passed through each other where the guarantee was out of force and the guard's
    // finer computations did not prevent it (the frame's warning says so).
    status.add("self-collision crossed pairs", self.crossed);
    // The longest triangle edge over the longest for which the guarantee holds: above 1 the cloth is
    // stretched too far for "never passes through itself" to be promised (doc/PHYSICS.md).
    status.add("self-collision stretch ratio", self.stretch_ratio);
  }
  // Ids, so that a client can see whether its grasp is still held.
  status.add("grasps held", core::idList(simulation_->grasps()));
  if (!non_finite.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR, "not finite: " + join(non_finite, ", "));
  }
  unstable_frames_ = 0;
  recovery_.clear();
  dropped_frames_ = 0;
  window_sim_s_ = 0.0;
  window_start_ = now;
  frame_budget_.clear();
}

bool ClothNode::onSaveState(cloth_sim::SaveState::Request& request, cloth_sim::SaveState::Response& response) {
  std::string error = core::textLengthProblem("path", request.path);
  if (!error.empty() || !core::writeStateFile(request.path, simulation_->snapshot(), &error)) {
    response.success = false;
    response.message = "not saved: " + error;
    return true;
  }
  response.success = true;
  response.message = "saved frame " + std::to_string(simulation_->state().frame) + " to " + request.path;
  ROS_INFO("cloth_node: %s", response.message.c_str());
  return true;
}

bool ClothNode::onLoadState(cloth_sim::LoadState::Request& request, cloth_sim::LoadState::Response& response) {
  applyPendingGrasps();  // commands received before the request apply to the cloth they were sent to
  // Messages name the path and numbers only: never text from the file (any ROS peer may ask).
  const auto refuse = [&response](const std::string& reason) {
    response.success = false;
    response.message = "not loaded: " + reason + "; the running cloth is untouched";
    return true;
  };
  core::SimulationSnapshot snapshot;
  std::string error = core::textLengthProblem("path", request.path);
  if (!error.empty() || !core::readStateFile(request.path, &snapshot, &error)) return refuse(error);
  const core::ClothGrid& grid = simulation_->grid();
  if (snapshot.options.rows != grid.rows || snapshot.options.cols != grid.cols) {
    return refuse(request.path + " holds a " + std::to_string(snapshot.options.rows) + "x" +
                  std::to_string(snapshot.options.cols) + " cloth, the running scene is " + std::to_string(grid.rows) +
                  "x" + std::to_string(grid.cols) + ": load a scene of that size first (~load_scene)");
  }
  Eigen::Matrix3Xf colors;
  const bool new_texture = snapshot.options.texture != simulation_->options().texture;
  if (new_texture && !core::sceneVertexColors(snapshot.options.texture, grid.uv, &colors, &error)) {
    // The reason without the texture's name, which is text from the file.
    const std::string named = "texture " + snapshot.options.texture + ": ";
    return refuse(error.rfind(named, 0) == 0 ? "its texture does not load (" + error.substr(named.size()) + ")"
                                             : "its texture does not load");
  }
  // The node's URDF colliders join every state it loads, as every scene: those the file does not hold (it
  // was saved by a node without this URDF) are added, unposed until their frames come. The file's own
  // colliders stay, whichever node's URDF they came from.
  std::size_t urdf_added = 0;
  for (const core::FrameCollider& link : urdf_colliders_) {
    std::vector<core::FrameCollider>& frames = snapshot.options.colliders.frames;
    if (std::find(frames.begin(), frames.end(), link) != frames.end()) continue;
    frames.push_back(link);
    snapshot.inputs.frame_colliders.emplace_back();
    ++urdf_added;
  }
  const std::vector<core::Grasp> grasps_before = simulation_->grasps();
  const std::vector<core::Gripper> grippers_before = simulation_->grippers();
  if (!simulation_->restore(snapshot, &error)) return refuse(error);
  grippers_->synchronize();  // the file's grippers follow their frames by name
  if (mouse_) {
    // A drag's grasp is the file's now, or gone; one the file holds is let go at the next mouse-down.
    const std::vector<core::Grasp>& held = simulation_->grasps();
    mouse_->endDrag(std::any_of(held.begin(), held.end(),
                                [](const core::Grasp& grasp) { return grasp.id == MouseDrag::kMouseGraspId; }));
  }
  cancelStep("~load_state replaced the state");
  if (new_texture) simulation_->setVertexColors(colors);
  timer_.setPeriod(ros::Duration(simulation_->options().frameDuration_s()));
  mesh_schedule_ = std::make_unique<MeshSchedule>(meshRate_hz());  // the file's frame rate, if that is it
  last_report_ = core::FrameReport();
  step_cost_ms_ = 0.0;  // the file's options (integrator, substeps, tuning) may cost another amount a frame
  asleep_ = false;
  forgetPublished();  // the loaded cloth goes out with the state, whatever the clock reads
  reanchor();  // the loaded frame is due now: the run continues from here at the frame rate
  pushConfig();
  publish(ros::Time::now());
  std::ostringstream message;
  message << "loaded frame " << simulation_->state().frame << " (t = " << simulation_->state().time_s << " s, "
          << grid.rows << "x" << grid.cols << ", " << simulation_->grasps().size() << " grasps) from " << request.path
          << (urdf_added > 0 ? "; added the URDF's " + std::to_string(urdf_added) + " colliders it did not hold" : "")
          << letGoText(core::letGo(grasps_before, simulation_->grasps()), core::letGo(grippers_before, simulation_->grippers()));
  response.success = true;
  response.message = message.str();
  ROS_INFO("cloth_node: %s", response.message.c_str());
  return true;
}

}  // namespace cloth_sim
