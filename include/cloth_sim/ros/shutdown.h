// Clean shutdown on SIGINT and SIGTERM, within a bounded time even when a frame cannot be interrupted.
#pragma once

#include <ros/callback_queue_interface.h>

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>

namespace cloth_sim {

/// Makes SIGINT and SIGTERM start a shutdown. The handler only notes the signal: the node answers a
/// ~step in progress (success=false, "the node is shutting down (SIGTERM)") and then asks roscpp to shut
/// down, which unregisters the node from the master and ends ros::spin(). Shutting roscpp down from the
/// handler itself closed the service connection before that answer was written, and the caller got a
/// transport error. roscpp's own handler covers SIGINT only, so a SIGTERM (what roslaunch escalates to,
/// and what service managers and containers send) killed the node with 143 and left its registration
/// behind. Call after ros::init with ros::init_options::NoSigintHandler.
void installShutdownSignals();

/// True once SIGINT or SIGTERM came (any thread).
bool shutdownSignalled();
/// "SIGINT" or "SIGTERM" (the first that came), or "" before either.
std::string shutdownSignalName();

/// A callback that asks roscpp to shut down, for a callback queue: it runs after the callbacks queued
/// before it (the node queues it behind a ~step answer).
class ShutdownRequest : public ros::CallbackInterface {
 public:
  CallResult call() override;
};

/// Asks roscpp to shut down if the node has not done so kAnswerGrace_s after a signal (a frame in
/// progress keeps the spin thread from answering), and ends the process if it is still busy kGrace_s
/// after a shutdown began: one frame cannot be interrupted (a 512x512 rk4 frame takes tens of seconds),
/// and by then roscpp has unregistered the node, so leaving without finishing the frame loses nothing.
class ShutdownWatchdog {
 public:
  static constexpr double kAnswerGrace_s = 1.0;
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
