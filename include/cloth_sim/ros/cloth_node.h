// The ROS face of the simulator: parameters in, a timer that advances frames, topics/services/tf out.
// Single-threaded: every callback that touches the simulation runs from ros::spin(), so none of them races
// another. The one exception is ~step's service callback, which runs on its own thread only to wait: it
// hands its request to the spin thread, which runs the frames in chunks between the other callbacks.
#pragma once

#include "cloth_sim/ClothConfig.h"
#include "cloth_sim/Grasp.h"
#include "cloth_sim/LoadScene.h"
#include "cloth_sim/LoadState.h"
#include "cloth_sim/SaveState.h"
#include "cloth_sim/Step.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/ros/conversions.h"
#include "cloth_sim/ros/frame_budget.h"
#include "cloth_sim/ros/depth_cameras.h"
#include "cloth_sim/ros/frame_inputs.h"
#include "cloth_sim/ros/grippers.h"
#include "cloth_sim/ros/robot_colliders.h"
#include "cloth_sim/ros/mouse_drag.h"
#include "cloth_sim/ros/mesh_schedule.h"
#include "cloth_sim/ros/grasp_queue.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/Vector3Stamped.h>
#include <ros/ros.h>
#include <std_srvs/SetBool.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <ros/callback_queue.h>
#include <ros/spinner.h>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace cloth_sim {

/// Topic, service and parameter names other nodes are written against (all private, under ~).
struct Names {
  static constexpr const char* kMeshTopic = "mesh";
  static constexpr const char* kStateTopic = "state";
  static constexpr const char* kCollidersTopic = "colliders";
  static constexpr const char* kWindTopic = "wind";
  static constexpr const char* kGraspTopic = "grasp";
  static constexpr const char* kResetService = "reset";
  static constexpr const char* kPauseService = "pause";
  static constexpr const char* kStepService = "step";
  static constexpr const char* kLoadSceneService = "load_scene";
  /// The whole simulation to and from a state file (doc/STATE_FILE.md).
  static constexpr const char* kSaveStateService = "save_state";
  static constexpr const char* kLoadStateService = "load_state";
  static constexpr const char* kSceneParam = "scene";
  static constexpr const char* kFrameIdParam = "frame_id";
  /// Mesh markers per second at most (the cloth still advances at the frame rate).
  static constexpr const char* kMeshRateParam = "mesh_rate";
  /// When set, frame_id is published in tf as a static identity child of this frame (so rviz, whose fixed
  /// frame is frame_id, finds it in every scene, with or without sphere frames).
  static constexpr const char* kParentFrameParam = "parent_frame_id";
  /// The sphere colliders' tf frames are this prefix and the sphere's index (children of frame_id): two
  /// nodes with spheres on one tf tree need different prefixes, or each moves the other's frames.
  static constexpr const char* kSphereFramePrefixParam = "sphere_frame_prefix";
  /// dynamic_reconfigure's namespace: ~tuning/set_parameters, ~tuning/parameter_updates.
  static constexpr const char* kTuningNamespace = "tuning";
  /// The paper's mouse in rviz: an interactive marker server under ~mouse (~mouse/feedback, ~mouse/update).
  static constexpr const char* kMouseNamespace = "mouse";
  /// The name of the parameter holding a URDF whose links' collision shapes become frame colliders (empty:
  /// none). Resolved in the node's namespace, as robot_state_publisher resolves its own.
  static constexpr const char* kRobotDescriptionParam = "robot_description";
};

class ClothNode {
 public:
  /// Most frames one step service call may ask for.
  static constexpr std::uint32_t kMaxStepFrames = 10000;
  /// Most wall time one ~step call may be expected to take (frames times the measured cost of the last
  /// frame); a longer request is refused with the number of frames that would fit.
  static constexpr double kMaxStepWork_s = 30.0;
  /// A running ~step stops (success=false) once its wall time passes kMaxStepWork_s times this: its
  /// estimate came from one earlier frame, and a frame can grow dearer as the cloth moves.
  static constexpr double kStepOverrunFactor = 2.0;
  /// Wall time one chunk of ~step frames may take before the node serves its other callbacks again.
  static constexpr double kStepChunk_s = 0.05;
  /// Most frames a late timer tick catches up in wall-time mode; further lag is dropped (and shows as a
  /// real-time factor below 1) rather than stalling the node.
  static constexpr int kMaxCatchUpFrames = 5;
  /// Most frames one tick catches up under /use_sim_time; a bigger leap of /clock is not simulated.
  static constexpr int kMaxSimTimeCatchUpFrames = 500;
  /// ~state messages roscpp holds per subscriber: a wall-time tick publishes up to kMaxCatchUpFrames (the
  /// frames it caught up on, then its own), one spare. Under /use_sim_time a /clock step of more frames
  /// sends more, back to back, and a subscriber keeps the newest of them.
  static constexpr std::uint32_t kStateQueue = kMaxCatchUpFrames + 1;
  /// Markers roscpp holds per subscriber: a viewer only ever wants the newest drawing.
  static constexpr std::uint32_t kMarkerQueue = 2;
  /// ~wind messages held between two spins; each replaces the wind, so the last one held is in force.
  static constexpr std::uint32_t kWindQueue = 10;
  /// ~grasp messages the subscriber holds for its receiving thread. That thread only files each one into
  /// GraspCommandQueue (microseconds), so this is reached only by a burst far beyond any hand's rate; the
  /// last command per id survives in the GraspCommandQueue whatever the spin thread is doing.
  static constexpr std::uint32_t kGraspSubscriberQueue = 1000;
  /// How often the spin thread looks whether SIGINT or SIGTERM came (it answers a pending ~step first).
  static constexpr double kSignalPoll_s = 0.05;
  /// How often, under /use_sim_time, the spin thread looks whether /clock went backwards, wall seconds.
  static constexpr double kClockWatch_s = 0.05;

  ClothNode(const ros::NodeHandle& node_handle, const ros::NodeHandle& private_handle);

  /// Reads and validates every parameter, builds the scene and starts the interface. False with the
  /// reason (naming the parameter, its value and the allowed range) if anything is invalid.
  bool start(std::string* error);

  /// Stops ~step's thread (it may be waiting on a step in progress) before the members it uses go.
  ~ClothNode();

 private:
  /// One ~step request: handed by the step service's thread to the spin thread, which checks it, runs its
  /// frames in chunks and fills `response`; `done` (under step_mutex_) tells the waiting service thread.
  struct StepJob {
    std::uint32_t frames = 0;
    bool started = false;
    bool done = false;
    /// Frames this job has advanced, counted as they are done: a difference of frame numbers underflowed
    /// when ~load_state put the counter back mid-step ("stopped after 18446744073709548616 frames").
    std::uint32_t frames_done = 0;
    /// No frame had run since the scene changed when the call came, so it had no cost to estimate from:
    /// its first frame's cost is checked against the rest instead.
    bool unestimated = false;
    std::chrono::steady_clock::time_point start_time;
    cloth_sim::Step::Response response;
  };
  class StepChunk;
  class GraspDrain;

  /// Builds a validated simulation from a scene (name or path), overlaid with the scene keys among
  /// `parameters`, the private namespace start() read (null, as for ~load_scene: the scene alone).
  std::unique_ptr<core::Simulation> buildSimulation(const std::string& scene, const XmlRpc::XmlRpcValue* parameters,
                                                    std::string* error) const;
  void install(std::unique_ptr<core::Simulation> simulation);

  void onTimer(const ros::TimerEvent& event);
  /// Advances up to `frames` frames; stops at, and returns false for, a frame the core rolled back. With
  /// `publish_between`, each frame but the last goes out on ~state (stamped with its frame time) before the
  /// next is computed, so a tick that catches up still gives ~state every frame; the caller publishes the last.
  bool advanceFrames(int frames, bool publish_between = false);
  /// Everything the node publishes each tick; ~state only if `with_state`.
  void publish(const ros::Time& stamp, bool with_state = true);
  /// After a reset or a replaced scene or state: the next publish sends everything, the mesh too, even at
  /// a stamp already sent (a held /clock).
  void forgetPublished();
  /// The ~mesh rate for the running scene: ~mesh_rate if it was given, else the scene's frame rate, Hz.
  double meshRate_hz() const;
  /// ~state alone, while someone subscribes and every field is finite; counted for the diagnostics' rate.
  void publishState(const ros::Time& stamp);
  /// The ROS time at which frame `frame` ends (from the anchor), or now if the clock is not anchored yet.
  ros::Time frameTime(std::uint64_t frame) const;
  void reanchor();

  void onWind(const geometry_msgs::Vector3Stamped::ConstPtr& message);
  /// On the grasp thread: files the command (the last per id is kept) and schedules a drain.
  void onGraspReceived(const cloth_sim::Grasp::ConstPtr& message);
  /// On the spin thread: applies every filed command, oldest first.
  void applyPendingGrasps();
  void applyGrasp(const cloth_sim::Grasp::ConstPtr& message);
  /// On the spin thread: after SIGINT or SIGTERM, answers the ~step in progress, then asks roscpp to shut
  /// down from the step service's thread, so that the answer is on the wire before the node leaves.
  void onSignalPoll(const ros::WallTimerEvent& event);
  /// Re-arms the frame timer when /clock went back behind the last tick (see kClockWatch_s).
  void onClockWatch(const ros::WallTimerEvent& event);
  bool onReset(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  bool onPause(std_srvs::SetBool::Request& request, std_srvs::SetBool::Response& response);
  /// On the step thread: hands the request to the spin thread and waits for its answer.
  bool onStep(cloth_sim::Step::Request& request, cloth_sim::Step::Response& response);
  /// On the spin thread: checks a new job, then runs its frames for up to kStepChunk_s and queues the
  /// next chunk behind whatever else arrived meanwhile.
  void runStepChunk(const std::shared_ptr<StepJob>& job);
  /// Why a new job may not run, or empty if it may.
  std::string refuseStep(const StepJob& job) const;
  /// Why `frames` more frames at the last frame's cost would take more than kMaxStepWork_s; "" if not, or
  /// if no frame has run since the scene or state was replaced (~load_scene, ~load_state: no cost to go by).
  std::string stepOverBudget(std::uint64_t frames) const;
  void queueStepChunk(const std::shared_ptr<StepJob>& job);
  /// Fills the job's answer and wakes the service thread waiting for it.
  void answerStep(StepJob& job, bool success, const std::string& message);
  /// Answers the job in progress after publishing the state it reached.
  void finishStep(bool success, const std::string& message);
  /// Stops the step in progress, if any, answering success=false with how far it got and why.
  void cancelStep(const std::string& reason);
  bool onLoadScene(cloth_sim::LoadScene::Request& request, cloth_sim::LoadScene::Response& response);
  bool onSaveState(cloth_sim::SaveState::Request& request, cloth_sim::SaveState::Response& response);
  /// All or nothing: a file that does not read, validate or fit the running grid leaves the cloth as it was.
  bool onLoadState(cloth_sim::LoadState::Request& request, cloth_sim::LoadState::Response& response);
  void onReconfigure(cloth_sim::ClothConfig& config, std::uint32_t level);
  /// Why a reconfigure request cannot be taken as it stands (a non-finite number, a wind over the limit,
  /// named), or "" (ranges are then checked by the core's validation in retune).
  std::string invalidReconfigureValue(const cloth_sim::ClothConfig& config) const;
  /// Publishes OptionLimits as the reconfigure ranges (the .cfg leaves them open so nothing is clamped).
  void publishReconfigureRanges();
  /// The options in force as a reconfigure config.
  void fillConfig(cloth_sim::ClothConfig* config) const;
  void pushConfig();
  /// Whether a reconfigure request changes no slider: every value is the one the sliders last showed (the
  /// options in force, the wind sliders' reconfigure_wind_).
  bool changesNoSlider(const cloth_sim::ClothConfig& config) const;
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

  ros::NodeHandle nh_;
  ros::NodeHandle pnh_;
  std::string frame_id_ = "world";
  std::string sphere_frame_prefix_ = kDefaultSphereFramePrefix;
  std::string scenes_dir_;
  std::unique_ptr<core::Simulation> simulation_;

  ros::Publisher mesh_pub_, state_pub_, colliders_pub_;
  /// The next ~colliders array begins with a DELETEALL: the scene was replaced, reset or restored since
  /// the last one (the displays may hold shapes this scene does not have).
  bool colliders_to_clear_ = true;
  ros::Subscriber wind_sub_, grasp_sub_;
  ros::ServiceServer reset_srv_, pause_srv_, step_srv_, load_scene_srv_;
  ros::ServiceServer save_state_srv_, load_state_srv_;
  ros::Timer timer_;
  ros::WallTimer signal_timer_;
  ros::WallTimer clock_watch_timer_;  ///< only under /use_sim_time
  ros::Time rearmed_after_tick_;      ///< the last tick after which onClockWatch re-armed the timer
  bool shutdown_begun_ = false;
  /// ~grasp is received on its own queue and thread, into grasp_commands_ (see kGraspSubscriberQueue).
  ros::CallbackQueue grasp_receive_queue_;
  std::unique_ptr<ros::AsyncSpinner> grasp_spinner_;
  GraspCommandQueue grasp_commands_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<DepthCameras> cameras_;  ///< ~points and the scene's cameras; after tf_buffer_, which it reads
  /// The stamp and frame the colliders, ~points, the cameras and the mouse's marker last went out with
  /// (once per stamp and frame; the spheres' tf once per stamp); none since the scene or state was
  /// replaced or reset, which go out at the next publish whatever its stamp.
  std::optional<ros::Time> last_published_stamp_;
  std::uint64_t last_published_frame_ = 0;
  FrameInputs frame_inputs_{tf_buffer_};  ///< stamped inputs into frame_id_ (tf-or-drop)
  std::unique_ptr<Grippers> grippers_;   ///< ~attach, ~detach, ~gripper_<id>/wrench; reads frame_inputs_
  std::unique_ptr<FrameColliderInputs> frame_colliders_;  ///< links on tf frames; reads frame_inputs_
  /// The URDF's collision shapes (~robot_description), added to every scene's frame_colliders.
  std::vector<core::FrameCollider> urdf_colliders_;
  std::unique_ptr<MouseDrag> mouse_;      ///< rviz drags the cloth through ~grasp's handling
  std::unique_ptr<dynamic_reconfigure::Server<cloth_sim::ClothConfig>> reconfigure_;
  boost::recursive_mutex reconfigure_mutex_;
  /// The wind the reconfigure sliders last showed: a reconfigure changes the wind only if they moved.
  Eigen::Vector3d reconfigure_wind_ = Eigen::Vector3d::Zero();
  diagnostic_updater::Updater diagnostics_;

  bool paused_ = false;
  /// The frame the last ~state showed (counted whether or not anyone subscribed; none before the first): a
  /// running tick with no new frame, the twin roscpp fires at once after a late tick, does not repeat it.
  std::optional<std::uint64_t> last_state_frame_;
  /// ~step's service runs on its own queue and thread, so its wait never blocks the spin thread.
  ros::CallbackQueue step_queue_;
  std::unique_ptr<ros::AsyncSpinner> step_spinner_;
  std::mutex step_mutex_;  ///< guards StepJob::done and ::response between the two threads
  std::condition_variable step_done_;
  std::shared_ptr<StepJob> active_step_;  ///< the job being run; touched by the spin thread only
  /// Set by the destructor: a service thread still waiting gives up instead of waiting for chunks that
  /// will never run.
  bool step_stopping_ = false;  ///< guarded by step_mutex_
  /// Frames are due at anchor_time_ + k / frame_rate (ROS time: wall clock, or /clock under use_sim_time).
  ros::Time anchor_time_;
  ros::Time last_tick_;  ///< to notice /clock going backwards
  std::unique_ptr<MeshSchedule> mesh_schedule_;  ///< at ~mesh_rate, or the scene's frame rate (meshRate_hz)
  /// ~mesh_rate as given at start-up, Hz; none: the running scene's frame rate, which ~load_scene and
  /// ~load_state may change.
  std::optional<double> mesh_rate_given_hz_;
  std::uint64_t anchor_frame_ = 0;
  bool anchored_ = false;

  // For diagnostics, since the last diagnostics update.
  core::FrameReport last_report_;  ///< the last frame computed (a frame slept through leaves it)
  bool asleep_ = false;            ///< the last frame was slept through (SceneOptions::sleep_speed_m_per_s)
  double step_cost_ms_ = 0.0;  ///< wall time of the last frame, ms
  int unstable_frames_ = 0;
  /// What the simulation did to recover from repeated rollbacks in this diagnostics window (empty: none).
  std::string recovery_;
  std::uint64_t dropped_frames_ = 0;
  double window_sim_s_ = 0.0;
  std::chrono::steady_clock::time_point window_start_;
  /// Whether this window's frames fit in the frame period (a WARN in the diagnostics when not).
  FrameBudget frame_budget_;
};

}  // namespace cloth_sim
