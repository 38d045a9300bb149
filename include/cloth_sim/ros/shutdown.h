// Clean shutdown on SIGINT and SIGTERM, within a bounded time even when a frame cannot be interrupted.
#pragma once

#include <condition_variable>
#include <mutex>
#include <thread>

namespace cloth_sim {

/// Makes SIGINT and SIGTERM ask roscpp to shut down: it unregisters the node from the master (from its
/// own poll thread) and ros::spin() returns. roscpp's own handler covers SIGINT only, so a SIGTERM (what
/// roslaunch escalates to, and what service managers and containers send) killed the node with 143 and
/// left its registration behind. Call after ros::init with ros::init_options::NoSigintHandler.
void installShutdownSignals();

/// Ends the process if it is still busy kGrace_s after a shutdown began: one frame cannot be interrupted
/// (a 512x512 rk4 frame takes tens of seconds), and by then roscpp has unregistered the node, so leaving
/// without finishing the frame loses nothing.
class ShutdownWatchdog {
 public:
  static constexpr double kGrace_s = 3.0;

  ShutdownWatchdog();
  /// Disarms it: the process got this far by itself.
  ~ShutdownWatchdog();

  ShutdownWatchdog(const ShutdownWatchdog&) = delete;
  ShutdownWatchdog& operator=(const ShutdownWatchdog&) = delete;

 private:
  void watch();

  std::mutex mutex_;
  std::condition_variable disarmed_;
  bool done_ = false;
  std::thread thread_;  ///< last: starts once the members it uses exist
};

}  // namespace cloth_sim
