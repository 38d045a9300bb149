// Keeps this process registered with the ROS master across a master restart.
//
// roscpp registers a topic or service with the master once, when it is advertised or subscribed. A
// restarted roscore starts empty: the node's old connections keep working, but no new subscriber finds its
// topics, no client finds its services, and nothing is logged. The watch asks the master every
// kCheckPeriod_s whether it knows this node; when it does not, it registers every publication,
// subscription and service of the process again (the node's own, and those of tf, dynamic_reconfigure,
// diagnostics and roscpp's /rosout alike), so nothing in the node has to be rebuilt.
#pragma once

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <ros/spinner.h>

#include <set>
#include <string>

namespace cloth_sim {

class MasterWatch {
 public:
  /// How often the master is asked, s of wall time (also how long a restart goes unnoticed at most).
  static constexpr double kCheckPeriod_s = 1.0;

  /// Starts checking, on a thread of its own: the calls to a slow or vanished master must not delay frames.
  MasterWatch();
  ~MasterWatch();

 private:
  void check(const ros::WallTimerEvent& event);
  /// True if the master lists this node; false if it does not or did not answer.
  bool masterKnowsThisNode() const;
  /// Remembers the services the master lists for this node: roscpp offers no list of its own, and a
  /// restarted master has forgotten them.
  void rememberServices();
  /// Registers every publication, subscription and remembered service again; false with what failed.
  bool registerAgain(std::string* report) const;

  bool master_lost_ = false;  ///< the master stopped answering and has not been seen since
  std::set<std::string> services_;
  ros::CallbackQueue queue_;
  ros::WallTimer timer_;
  ros::AsyncSpinner spinner_;  ///< last: stopped first, before what check() uses
};

}  // namespace cloth_sim
