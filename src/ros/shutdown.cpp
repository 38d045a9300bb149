#include "cloth_sim/ros/shutdown.h"

#include <ros/ros.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>

namespace cloth_sim {

namespace {

/// How often the watchdog looks whether a shutdown has begun.
constexpr std::chrono::milliseconds kShutdownPoll{100};

/// Only sets roscpp's shutdown flag, as roscpp's own SIGINT handler does, so it is safe in a signal handler.
void requestShutdown(int) { ros::requestShutdown(); }

}  // namespace

void installShutdownSignals() {
  std::signal(SIGINT, requestShutdown);
  std::signal(SIGTERM, requestShutdown);
}

ShutdownWatchdog::ShutdownWatchdog() : thread_([this] { watch(); }) {}

ShutdownWatchdog::~ShutdownWatchdog() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
  }
  disarmed_.notify_all();
  thread_.join();
}

void ShutdownWatchdog::watch() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!done_ && !ros::isShuttingDown()) disarmed_.wait_for(lock, kShutdownPoll);
  if (done_) return;
  if (disarmed_.wait_for(lock, std::chrono::duration<double>(kGrace_s), [this] { return done_; })) return;
  // roscpp's logging is shut down with the rest of it by now: say it on stderr.
  std::fprintf(stderr, "[cloth_node] still busy %.0f s after the shutdown began (a frame in progress cannot be "
               "interrupted); the node is unregistered, exiting without finishing it\n", kGrace_s);
  std::_Exit(EXIT_SUCCESS);
}

}  // namespace cloth_sim
