// Grippers on tf frames (issue 14): the ~attach and ~detach services, each gripper's frame looked up in
// tf at every frame's time and handed to the core, and ~gripper_<id>/wrench published after every frame.
// Runs on the spin thread with the rest of the node (services and timer never race).
#pragma once

#include "cloth_sim/Attach.h"
#include "cloth_sim/Detach.h"
#include "cloth_sim/core/simulation.h"
#include "cloth_sim/ros/frame_inputs.h"

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <map>
#include <string>

namespace cloth_sim {

class Grippers {
 public:
  static constexpr const char* kAttachService = "attach";
  static constexpr const char* kDetachService = "detach";
  /// ~gripper_<id>/wrench: geometry_msgs/WrenchStamped in the gripper's frame.
  static constexpr const char* kWrenchTopicPrefix = "gripper_";
  static constexpr const char* kWrenchTopicSuffix = "/wrench";

  /// `simulation` returns the running simulation (the node replaces it on ~load_scene). `next_frame_end`
  /// returns the time the node's next frame ends as its frame clock stands, the time its next beforeFrame
  /// (a tick's, or a ~step's) looks a new gripper's frame up at: while paused it may lie before now (the
  /// clock stopped at ~pause) or after it (~step runs frames faster than the clock).
  Grippers(ros::NodeHandle& private_handle, const FrameInputs& frames, std::string world_frame,
           std::function<core::Simulation&()> simulation, std::function<ros::Time()> next_frame_end);

  /// Before a frame that ends at `frame_end`: moves each gripper to its frame's pose at that time (or the
  /// newest tf has, if tf has none that late yet).
  void beforeFrame(const ros::Time& frame_end);
  /// After a frame: publishes each gripper's wrench stamped `stamp` and notes the particles that slipped.
  void afterFrame(const ros::Time& stamp);
  /// After the simulation was replaced, reset or restored: grippers it no longer has are forgotten (their
  /// topics closed), and grippers it has that were not attached here (a loaded state file) follow their
  /// frame by name from now on.
  void synchronize();
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

 private:
  struct Held {
    std::string frame;
    ros::Publisher wrench;
    ros::Time last_seen;          ///< stamp of the newest transform of `frame` used
    bool lost = false;            ///< the newest transform is older than kFrameLostAfter_s (or none)
    std::string lost_reason;
    std::uint64_t slipped = 0;    ///< particles that slipped out so far
  };

  bool onAttach(cloth_sim::Attach::Request& request, cloth_sim::Attach::Response& response);
  bool onDetach(cloth_sim::Detach::Request& request, cloth_sim::Detach::Response& response);
  /// Starts following gripper `id` on `frame`: its entry and its wrench topic.
  Held& follow(std::uint32_t id, const std::string& frame);

  ros::NodeHandle pnh_;
  const FrameInputs& frames_;
  std::string world_frame_;
  std::function<core::Simulation&()> simulation_;
  std::function<ros::Time()> next_frame_end_;
  ros::ServiceServer attach_srv_, detach_srv_;
  std::map<std::uint32_t, Held> held_;
};

}  // namespace cloth_sim
