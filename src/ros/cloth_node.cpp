#include "cloth_sim/ros/cloth_node.h"

#include "cloth_sim/io/scene_file.h"
#include "cloth_sim/io/texture.h"
#include "cloth_sim/ros/conversions.h"

#include <ros/package.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <cmath>
#include <set>
#include <sstream>

namespace cloth_sim {

namespace {

/// Private parameters that belong to the node rather than to the scene.
const std::set<std::string>& nodeOnlyParameters() {
  static const std::set<std::string> names{Names::kSceneParam, Names::kFrameIdParam, Names::kMeshRateParam,
                                           Names::kParentFrameParam, Names::kTuningNamespace};
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
/// A mesh counts as due this fraction of a frame before its period is up (timer ticks jitter).
constexpr double kMeshPeriodTolerance = 0.5;
constexpr double kMillisecondsPerSecond = 1000.0;

}  // namespace

ClothNode::ClothNode(const ros::NodeHandle& node_handle, const ros::NodeHandle& private_handle)
    : nh_(node_handle), pnh_(private_handle) {}

bool ClothNode::start(std::string* error) {
  // The whole private namespace, read once: each node parameter's type is checked by optionalParameter,
  // each scene key's by the scene-file reader (buildSimulation), so no wrong type falls back silently.
  XmlRpc::XmlRpcValue parameters;
  if (!ros::param::get(pnh_.getNamespace(), parameters)) parameters = XmlRpc::XmlRpcValue();
  std::string parent_frame;
  std::string scene = kDefaultScene;
  double mesh_rate_hz = 0.0;  // not given: the frame rate, known once the scene is built
  if (!optionalParameter(parameters, Names::kFrameIdParam, &frame_id_, error) ||
      !optionalParameter(parameters, Names::kParentFrameParam, &parent_frame, error) ||
      !optionalParameter(parameters, Names::kSceneParam, &scene, error) ||
      !optionalParameter(parameters, Names::kMeshRateParam, &mesh_rate_hz, error)) {
    return false;
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
  scenes_dir_ = ros::package::getPath("cloth_sim") + "/config/scenes";
  std::unique_ptr<core::Simulation> simulation = buildSimulation(scene, true, error);
  if (!simulation) return false;
  simulation_ = std::move(simulation);
  // The mesh is the heavy message (each vertex six times, with colours): a viewer may want it less often.
  const bool mesh_rate_given =
      parameters.getType() == XmlRpc::XmlRpcValue::TypeStruct && parameters.hasMember(Names::kMeshRateParam);
  if (!mesh_rate_given) mesh_rate_hz = simulation_->options().frame_rate_hz;
  if (!std::isfinite(mesh_rate_hz) || mesh_rate_hz <= 0.0 || mesh_rate_hz > core::OptionLimits::kMaxFrameRateHz) {
    *error = "parameter ~mesh_rate = " + std::to_string(mesh_rate_hz) + ": must be in (0, " +
             std::to_string(core::OptionLimits::kMaxFrameRateHz) + "] Hz";
    return false;
  }
  mesh_period_s_ = 1.0 / mesh_rate_hz;

  mesh_pub_ = pnh_.advertise<visualization_msgs::Marker>(Names::kMeshTopic, 2);
  state_pub_ = pnh_.advertise<cloth_sim::ClothState>(Names::kStateTopic, 2);
  colliders_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>(Names::kCollidersTopic, 2);
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_);
  wind_sub_ = pnh_.subscribe(Names::kWindTopic, 10, &ClothNode::onWind, this);
  grasp_sub_ = pnh_.subscribe(Names::kGraspTopic, 10, &ClothNode::onGrasp, this);
  reset_srv_ = pnh_.advertiseService(Names::kResetService, &ClothNode::onReset, this);
  pause_srv_ = pnh_.advertiseService(Names::kPauseService, &ClothNode::onPause, this);
  step_srv_ = pnh_.advertiseService(Names::kStepService, &ClothNode::onStep, this);
  load_scene_srv_ = pnh_.advertiseService(Names::kLoadSceneService, &ClothNode::onLoadScene, this);

  // In its own namespace: dynamic_reconfigure leaves its values on the parameter server, where the next
  // start-up would otherwise read them as overrides of the next scene.
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<cloth_sim::ClothConfig>>(
      reconfigure_mutex_, ros::NodeHandle(pnh_, Names::kTuningNamespace));
  publishReconfigureRanges();
  pushConfig();  // before the callback, so its first call carries the scene's values, not the .cfg defaults
  reconfigure_->setCallback([this](cloth_sim::ClothConfig& config, std::uint32_t level) { onReconfigure(config, level); });

  diagnostics_.setHardwareID("cloth_sim");
  diagnostics_.add("simulation", this, &ClothNode::diagnose);
  window_start_ = std::chrono::steady_clock::now();

  if (!parent_frame.empty()) {
    geometry_msgs::TransformStamped identity;
    identity.header.stamp = ros::Time::now();
    identity.header.frame_id = parent_frame;
    identity.child_frame_id = frame_id_;
    identity.transform.rotation.w = 1.0;
    static_broadcaster_.sendTransform(identity);
  }

  timer_ = pnh_.createTimer(ros::Duration(simulation_->options().frameDuration_s()), &ClothNode::onTimer, this);
  ROS_INFO("cloth_node: scene '%s', %dx%d particles, %s with %d substeps, %.0f Hz, frame '%s'",
           simulation_->options().name.c_str(), simulation_->grid().rows, simulation_->grid().cols,
           core::integratorName(simulation_->options().integrator), simulation_->options().substeps,
           simulation_->options().frame_rate_hz, frame_id_.c_str());
  return true;
}

std::unique_ptr<core::Simulation> ClothNode::buildSimulation(const std::string& scene, bool overlay_parameters,
                                                       std::string* error) const {
  const std::string path = core::resolveScenePath(scene, scenes_dir_);
  core::SceneOptions options;
  std::vector<std::string> errors;
  if (!core::loadSceneFile(path, &options, &errors)) {
    *error = "scene '" + scene + "': " + join(errors, "; ") + " (built-in scenes: " +
             join(core::builtinSceneNames(scenes_dir_), ", ") + ")";
    return nullptr;
  }
  if (overlay_parameters) {
    XmlRpc::XmlRpcValue parameters;
    if (ros::param::get(pnh_.getNamespace(), parameters) && parameters.getType() == XmlRpc::XmlRpcValue::TypeStruct) {
      YAML::Node overlay(YAML::NodeType::Map);
      const std::vector<std::string>& keys = core::sceneKeys();
      for (auto& entry : parameters) {
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
  }
  std::unique_ptr<core::Simulation> simulation;
  try {
    simulation = std::make_unique<core::Simulation>(options);
  } catch (const std::exception& e) {  // validated options do not throw; memory may still run out
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
  simulation_ = std::move(simulation);
  timer_.setPeriod(frame_period);
  last_report_ = core::FrameReport();
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
        std::max(0.0, (now - anchor_time_).toSec() * simulation_->options().frame_rate_hz);
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
      advanceFrames(static_cast<int>(most));
      reanchor();
    } else if (behind > 0 && !advanceFrames(static_cast<int>(behind))) {
      reanchor();  // a frame was rolled back: owe nothing, try again at the next tick
    }
  }
  publish(now);
  diagnostics_.update();
}

bool ClothNode::advanceFrames(int frames) {
  for (int k = 0; k < frames; ++k) {
    const auto start = std::chrono::steady_clock::now();
    last_report_ = simulation_->advanceFrame();
    step_cost_ms_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() * kMillisecondsPerSecond;
    if (!last_report_.reason.empty()) ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: %s", last_report_.reason.c_str());
    if (!last_report_.stable) {
      ++unstable_frames_;
      return false;  // the same frame would diverge again right away: leave it to the next tick
    }
    window_sim_s_ += simulation_->options().frameDuration_s();
  }
  return true;
}

void ClothNode::publish(const ros::Time& stamp) {
  // The core rolls a diverged frame back, so this holds; rviz crashes on NaN markers, so check anyway.
  if (!core::isFiniteAndBounded(simulation_->state(), core::Simulation::kDivergenceBound_m)) {
    ROS_ERROR_THROTTLE(kWarnThrottle_s, "cloth_node: state is not finite; not publishing");
    return;
  }
  // A mesh is due once a mesh period has passed since the last one (a frame's worth of timer jitter
  // early counts as on time); time running backwards (a looping /clock) makes one due at once.
  const double since_mesh_s = (stamp - last_mesh_).toSec();
  const bool mesh_due = last_mesh_.isZero() || since_mesh_s < 0.0 ||
                        since_mesh_s >= mesh_period_s_ - kMeshPeriodTolerance * simulation_->options().frameDuration_s();
  if (mesh_due && mesh_pub_.getNumSubscribers() > 0) {
    mesh_pub_.publish(toMeshMarker(*simulation_, frame_id_, stamp));
    last_mesh_ = stamp;
  }
  if (state_pub_.getNumSubscribers() > 0) {
    const cloth_sim::ClothState state = toStateMessage(*simulation_, frame_id_, stamp);
    const std::vector<std::string> non_finite = nonFiniteFields(state);
    if (non_finite.empty()) {
      state_pub_.publish(state);
    } else {
      ROS_ERROR_THROTTLE(kWarnThrottle_s, "cloth_node: not publishing ~state: %s not finite",
                         join(non_finite, ", ").c_str());
    }
  }
  if (colliders_pub_.getNumSubscribers() > 0 && !simulation_->options().colliders.empty()) {
    colliders_pub_.publish(toColliderMarkers(*simulation_, frame_id_, stamp));
  }
  const auto transforms = toSphereTransforms(*simulation_, frame_id_, stamp);
  if (!transforms.empty()) tf_broadcaster_.sendTransform(transforms);
}

void ClothNode::onWind(const geometry_msgs::Vector3Stamped::ConstPtr& message) {
  geometry_msgs::Vector3Stamped wind = *message;
  const Eigen::Vector3d raw(wind.vector.x, wind.vector.y, wind.vector.z);
  if (!raw.allFinite() || raw.norm() > core::OptionLimits::kMaxWindSpeed_m_per_s) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~wind (%g, %g, %g) m/s: must be finite and below %g m/s",
                      raw.x(), raw.y(), raw.z(), core::OptionLimits::kMaxWindSpeed_m_per_s);
    return;
  }
  if (!wind.header.frame_id.empty() && wind.header.frame_id != frame_id_) {
    try {
      const auto transform = tf_buffer_.lookupTransform(frame_id_, wind.header.frame_id, ros::Time(0));
      tf2::doTransform(*message, wind, transform);  // a free vector: rotation only
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~wind in frame '%s': %s",
                        message->header.frame_id.c_str(), e.what());
      return;
    }
  }
  simulation_->setWindVelocity(Eigen::Vector3d(wind.vector.x, wind.vector.y, wind.vector.z));
}

void ClothNode::onGrasp(const cloth_sim::Grasp::ConstPtr& message) {
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
  if (!target.header.frame_id.empty() && target.header.frame_id != frame_id_) {
    try {
      const auto transform = tf_buffer_.lookupTransform(frame_id_, target.header.frame_id, ros::Time(0));
      geometry_msgs::PointStamped in_frame;
      tf2::doTransform(target, in_frame, transform);
      target = in_frame;
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp id %u in frame '%s': %s", message->id,
                        message->header.frame_id.c_str(), e.what());
      return;
    }
  }
  std::string error;
  const core::GraspRequest request =
      toGraspRequest(*message, Eigen::Vector3d(target.point.x, target.point.y, target.point.z));
  if (!simulation_->grab(request, &error)) {
    ROS_WARN_THROTTLE(kWarnThrottle_s, "cloth_node: dropped ~grasp id %u: %s", message->id, error.c_str());
  }
}

bool ClothNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  simulation_->reset();
  reanchor();
  publish(ros::Time::now());
  response.success = true;
  response.message = "scene '" + simulation_->options().name + "' back at frame 0";
  return true;
}

bool ClothNode::onPause(std_srvs::SetBool::Request& request, std_srvs::SetBool::Response& response) {
  paused_ = request.data;
  reanchor();
  response.success = true;
  response.message = paused_ ? "paused at frame " + std::to_string(simulation_->state().frame) : "running";
  return true;
}

bool ClothNode::onStep(cloth_sim::Step::Request& request, cloth_sim::Step::Response& response) {
  response.sim_time = simulation_->state().time_s;
  if (!paused_) {
    response.success = false;
    response.message = "not paused: call ~pause with data=true first";
    return true;
  }
  if (request.frames == 0 || request.frames > kMaxStepFrames) {
    response.success = false;
    response.message = "frames = " + std::to_string(request.frames) + ": must be in [1, " +
                       std::to_string(kMaxStepFrames) + "]";
    return true;
  }
  const std::uint64_t frame_before = simulation_->state().frame;
  response.success = advanceFrames(static_cast<int>(request.frames));
  publish(ros::Time::now());
  response.sim_time = simulation_->state().time_s;
  const std::uint64_t advanced = simulation_->state().frame - frame_before;
  response.message = response.success ? "advanced " + std::to_string(advanced) + " frames"
                                      : "stopped after " + std::to_string(advanced) + " frames: " + last_report_.reason;
  return true;
}

bool ClothNode::onLoadScene(cloth_sim::LoadScene::Request& request, cloth_sim::LoadScene::Response& response) {
  // All or nothing: the new scene is read, validated, built and textured completely before it replaces
  // the running one; any failure answers with the reason and the old scene carries on.
  std::string error;
  std::unique_ptr<core::Simulation> simulation;
  try {
    simulation = buildSimulation(request.scene, false, &error);
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
          << simulation_->grid().cols << ")";
  response.message = message.str();
  ROS_INFO("cloth_node: %s", response.message.c_str());
  return true;
}

void ClothNode::onReconfigure(cloth_sim::ClothConfig& config, std::uint32_t) {
  // The .cfg gives no ranges, so dynamic_reconfigure's server clamps nothing (it clamped -5 to 0 and inf
  // to 1e4 silently, and let NaN through): every value arrives as sent and is checked here, and a
  // refused change keeps the whole previous configuration.
  const std::string invalid = invalidReconfigureValue(config);
  if (!invalid.empty()) {
    ROS_WARN("cloth_node: reconfigure refused: %s; the previous values stay", invalid.c_str());
    fillConfig(&config);
    reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
    return;
  }
  core::SceneOptions options = simulation_->options();
  const double stiffness[core::kSpringKindCount] = {config.structural_stiffness, config.shear_stiffness,
                                              config.bend_stiffness};
  const double damping[core::kSpringKindCount] = {config.structural_damping, config.shear_damping, config.bend_damping};
  for (int k = 0; k < core::kSpringKindCount; ++k) {
    options.springs[k].stiffness_N_per_m = stiffness[k];
    options.springs[k].damping_N_s_per_m = damping[k];
  }
  options.air_damping_N_s_per_m = config.air_damping;
  // The wind sliders count only when they moved: comparing them with the wind in force would undo every
  // wind that came in on ~wind (the sliders do not follow the topic) at the next reconfigure of anything.
  const Eigen::Vector3d wind(config.wind_x, config.wind_y, config.wind_z);
  std::string error;
  if (!core::parseIntegratorName(config.integrator, &options.integrator)) {
    error = "integrator '" + config.integrator + "' is unknown";
  }
  options.substeps = config.substeps;
  options.solver.tolerance = config.solver_tolerance;
  options.solver.max_iterations = config.solver_max_iterations;
  if (!error.empty() || !simulation_->retune(options, &error)) {
    ROS_WARN("cloth_node: reconfigure refused: %s; the previous values stay", error.c_str());
  } else if (wind != reconfigure_wind_) {
    simulation_->setWindVelocity(wind);  // the wind is an input, not an option: retune leaves it alone
  }
  // Answer and publish what is in force (a refused change is not; a ~wind is), so the sliders follow.
  fillConfig(&config);
  reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
}

std::string ClothNode::invalidReconfigureValue(const cloth_sim::ClothConfig& config) const {
  const std::pair<const char*, double> numbers[] = {
      {"structural_stiffness", config.structural_stiffness}, {"structural_damping", config.structural_damping},
      {"shear_stiffness", config.shear_stiffness},           {"shear_damping", config.shear_damping},
      {"bend_stiffness", config.bend_stiffness},             {"bend_damping", config.bend_damping},
      {"air_damping", config.air_damping},                   {"wind_x", config.wind_x},
      {"wind_y", config.wind_y},                             {"wind_z", config.wind_z},
      {"solver_tolerance", config.solver_tolerance}};
  for (const auto& [field, value] : numbers) {
    if (!std::isfinite(value)) return std::string(field) + " = " + std::to_string(value) + ": must be finite";
  }
  // The sliders are the wind's components; its magnitude is what ~wind and the scene files bound.
  const Eigen::Vector3d wind(config.wind_x, config.wind_y, config.wind_z);
  if (wind != reconfigure_wind_ && wind.norm() > core::OptionLimits::kMaxWindSpeed_m_per_s) {
    std::ostringstream out;
    out << "wind_x, wind_y, wind_z = (" << wind.x() << ", " << wind.y() << ", " << wind.z() << "): magnitude "
        << wind.norm() << " m/s must be at most " << core::OptionLimits::kMaxWindSpeed_m_per_s << " m/s";
    return out.str();
  }
  return "";
}

void ClothNode::publishReconfigureRanges() {
  // The server clamps to the .cfg's ranges, which are left open; the ranges shown to rqt_reconfigure and
  // the clients (parameter_descriptions) are set here from OptionLimits, the ones validation enforces.
  using L = core::OptionLimits;
  cloth_sim::ClothConfig low = cloth_sim::ClothConfig::__getMin__();
  cloth_sim::ClothConfig high = cloth_sim::ClothConfig::__getMax__();
  for (double* field : {&low.structural_stiffness, &low.shear_stiffness, &low.bend_stiffness, &low.structural_damping,
                        &low.shear_damping, &low.bend_damping, &low.air_damping}) {
    *field = 0.0;
  }
  high.structural_stiffness = high.shear_stiffness = high.bend_stiffness = L::kMaxStiffnessN_per_m;
  high.structural_damping = high.shear_damping = high.bend_damping = high.air_damping = L::kMaxDampingN_s_per_m;
  low.wind_x = low.wind_y = low.wind_z = -L::kMaxWindSpeed_m_per_s;
  high.wind_x = high.wind_y = high.wind_z = L::kMaxWindSpeed_m_per_s;
  low.substeps = 1;
  high.substeps = L::kMaxSubsteps;
  low.solver_tolerance = L::kMinSolverTolerance;
  high.solver_tolerance = 1.0;
  low.solver_max_iterations = 1;
  high.solver_max_iterations = L::kMaxSolverIterations;
  reconfigure_->setConfigMin(low);
  reconfigure_->setConfigMax(high);
}

void ClothNode::fillConfig(cloth_sim::ClothConfig* config) const {
  const core::SceneOptions& o = simulation_->options();
  cloth_sim::ClothConfig& c = *config;
  c.structural_stiffness = o.springs[0].stiffness_N_per_m;
  c.structural_damping = o.springs[0].damping_N_s_per_m;
  c.shear_stiffness = o.springs[1].stiffness_N_per_m;
  c.shear_damping = o.springs[1].damping_N_s_per_m;
  c.bend_stiffness = o.springs[2].stiffness_N_per_m;
  c.bend_damping = o.springs[2].damping_N_s_per_m;
  c.air_damping = o.air_damping_N_s_per_m;
  const Eigen::Vector3d& wind = simulation_->inputs().wind_m_per_s;
  c.wind_x = wind.x();
  c.wind_y = wind.y();
  c.wind_z = wind.z();
  c.integrator = core::integratorName(o.integrator);
  c.substeps = o.substeps;
  c.solver_tolerance = o.solver.tolerance;
  c.solver_max_iterations = o.solver.max_iterations;
}

void ClothNode::pushConfig() {
  if (!reconfigure_) return;
  cloth_sim::ClothConfig config;
  fillConfig(&config);
  reconfigure_wind_ = Eigen::Vector3d(config.wind_x, config.wind_y, config.wind_z);
  reconfigure_->updateConfig(config);
}

void ClothNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const auto now = std::chrono::steady_clock::now();
  const double window_wall_s = std::chrono::duration<double>(now - window_start_).count();
  const double real_time_factor = window_wall_s > 0.0 ? window_sim_s_ / window_wall_s : 0.0;
  const core::EnergyReport energy = simulation_->energies();
  std::string problem;
  if (unstable_frames_ > 0) {
    problem = std::to_string(unstable_frames_) + " frames diverged and were rolled back: " + last_report_.reason;
  } else if (!last_report_.reason.empty()) {
    problem = last_report_.reason;
  } else if (dropped_frames_ > 0) {
    problem = std::to_string(dropped_frames_) + " frames dropped: the machine cannot keep up in real time";
  }
  if (problem.empty()) {
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, paused_ ? "paused" : "running");
  } else {
    status.summary(diagnostic_msgs::DiagnosticStatus::WARN, problem);
  }
  status.add("scene", simulation_->options().name);
  status.add("frame", simulation_->state().frame);
  std::vector<std::string> non_finite;  // never published as numbers: rviz and monitors choke on them
  addFiniteValue(status, "sim time [s]", simulation_->state().time_s, &non_finite);
  addFiniteValue(status, "step cost [ms]", step_cost_ms_, &non_finite);
  addFiniteValue(status, "real-time factor", real_time_factor, &non_finite);
  addFiniteValue(status, "kinetic energy [J]", energy.kinetic_J, &non_finite);
  addFiniteValue(status, "potential energy [J]", energy.potential_J, &non_finite);
  addFiniteValue(status, "max strain", simulation_->maxStructuralStrain(), &non_finite);
  status.add("integrator", core::integratorName(simulation_->options().integrator));
  status.add("substeps", simulation_->options().substeps);
  // implicit_euler's linear solve in the last frame: iterations per step, and whether it met its tolerance.
  const int steps = std::max(last_report_.substeps_used, 1);
  status.add("solver iterations per step", static_cast<double>(last_report_.steps.solver_iterations) / steps);
  status.add("solver converged", last_report_.steps.converged);
  status.add("paused", paused_);
  if (!non_finite.empty()) {
    status.mergeSummary(diagnostic_msgs::DiagnosticStatus::ERROR, "not finite: " + join(non_finite, ", "));
  }
  unstable_frames_ = 0;
  dropped_frames_ = 0;
  window_sim_s_ = 0.0;
  window_start_ = now;
}

}  // namespace cloth_sim
