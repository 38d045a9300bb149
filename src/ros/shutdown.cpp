#include "cloth_sim/ros/shutdown.h"

#include <ros/ros.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>

namespace cloth_sim {

namespace {

/// How often the watchdog looks whether a shutdown has begun.
constexpr std::chrono::milliseconds kShutdownPoll{100};

/// The first shutdown signal that came, 0 before. Process-wide by nature: a signal handler has nothing
/// else to write to. Lock-free, so the handler may store to it.
std::atomic<int>& signalReceived() {
  static std::atomic<int> received{0};
  static_assert(std::atomic<int>::is_always_lock_free, "a signal handler may only touch lock-free atomics");
  return received;
}

/// Only notes the signal (async-signal-safe); the node and the watchdog act on it.
void noteSignal(int signal_number) {
  int none = 0;
  signalReceived().compare_exchange_strong(none, signal_number);
}

}  // namespace

void installShutdownSignals() {
  signalReceived();  // constructed before any handler can run
  std::signal(SIGINT, noteSignal);
  std::signal(SIGTERM, noteSignal);
}

bool shutdownSignalled() { return signalReceived().load() != 0; }

std::string shutdownSignalName() {
  switch (signalReceived().load()) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    default:
      return "";
  }
}

ros::CallbackInterface::CallResult ShutdownRequest::call() {
  ros::requestShutdown();
  return Success;
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
  while (!done_ && !ros::isShuttingDown() && !shutdownSignalled()) disarmed_.wait_for(lock, kShutdownPoll);
  if (done_) return;
  // The node answers a pending ~step and asks for the shutdown itself; if a frame keeps it busy, or it is
  // not spinning yet, ask in its place.
  if (!ros::isShuttingDown() &&
      !disarmed_.wait_for(lock, std::chrono::duration<double>(kAnswerGrace_s),
                          [this] { return done_ || ros::isShuttingDown(); })) {
    ros::requestShutdown();
  }
  if (done_) return;
  if (disarmed_.wait_for(lock, std::chrono::duration<double>(kGrace_s), [this] { return done_; })) return;
  // roscpp's logging is shut down with the rest of it by now: say it on stderr.
  std::fprintf(stderr, "[cloth_node] still busy %.0f s after the shutdown began (a frame in progress cannot be "
               "interrupted); the node is unregistered, exiting without finishing it\n", kGrace_s);
  std::_Exit(EXIT_SUCCESS);
}

}  // namespace cloth_sim
