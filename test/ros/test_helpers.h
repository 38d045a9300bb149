// Helpers for the rostest client: topic monitors, service calls and subprocesses, all waiting on
// conditions with wall-clock deadlines (never fixed sleeps), so the suite works under /use_sim_time too.
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sys/wait.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace cloth_sim_test {

using Clock = std::chrono::steady_clock;

inline Clock::time_point deadlineIn(double seconds) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

/// Polls `condition` (every few ms) until it holds or `timeout_s` of wall time passes.
inline bool waitUntil(const std::function<bool()>& condition, double timeout_s) {
  const auto deadline = deadlineIn(timeout_s);
  while (!condition()) {
    if (Clock::now() > deadline || !ros::ok()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

/// Keeps every message of one topic (the last kKeep of them) with a running count, so a test can wait
/// for "a message received after this point that satisfies P".
template <typename M>
class Monitor {
 public:
  using Ptr = typename M::ConstPtr;
  static constexpr std::size_t kKeep = 2000;

  Monitor(ros::NodeHandle& nh, const std::string& topic, std::uint32_t queue_size = 100)
      : history_(std::make_shared<History>()) {
    // The callback holds the history, not the Monitor: a spinner thread may still be inside it when the
    // Monitor goes out of scope (shutting a subscriber down does not wait for a running callback; ASan
    // caught the write after free).
    std::shared_ptr<History> history = history_;
    subscriber_ = nh.subscribe<M>(topic, queue_size, [history](const Ptr& message) {
      std::lock_guard<std::mutex> lock(history->mutex);
      history->messages.push_back(message);
      if (history->messages.size() > kKeep) history->messages.pop_front();
      ++history->count;
      history->changed.notify_all();
    });
  }

  /// Messages received so far (a marker for waitFor's `since`).
  std::uint64_t count() const {
    std::lock_guard<std::mutex> lock(history_->mutex);
    return history_->count;
  }

  Ptr latest() const {
    std::lock_guard<std::mutex> lock(history_->mutex);
    return history_->messages.empty() ? Ptr() : history_->messages.back();
  }

  /// The first message numbered >= since (0-based, in arrival order) for which predicate holds, waiting
  /// up to timeout_s of wall time; null if none came.
  /// *index (if given) receives the message's number, so a later wait can start after it.
  Ptr waitFor(const std::function<bool(const M&)>& predicate, double timeout_s, std::uint64_t since = 0,
              std::uint64_t* index = nullptr) {
    const auto deadline = deadlineIn(timeout_s);
    History& h = *history_;
    std::unique_lock<std::mutex> lock(h.mutex);
    std::uint64_t next = since;
    bool timed_out = false;
    while (true) {
      const std::uint64_t first = h.count - h.messages.size();
      if (next < first) next = first;  // older ones were dropped from the history
      for (; next < h.count; ++next) {
        const Ptr& message = h.messages[next - first];
        if (predicate(*message)) {
          if (index) *index = next;
          return message;
        }
      }
      if (timed_out || !ros::ok()) return Ptr();
      // after a timeout, loop once more to look at what arrived meanwhile
      timed_out = h.changed.wait_until(lock, deadline) == std::cv_status::timeout;
    }
  }

  std::uint32_t publisherCount() const { return subscriber_.getNumPublishers(); }

  /// Any message received after `since`.
  Ptr waitForNext(double timeout_s, std::uint64_t since) {
    return waitFor([](const M&) { return true; }, timeout_s, since);
  }

 private:
  struct History {
    std::mutex mutex;
    std::condition_variable changed;
    std::deque<Ptr> messages;
    std::uint64_t count = 0;
  };
  std::shared_ptr<History> history_;
  ros::Subscriber subscriber_;  ///< after history_: unsubscribed first when the Monitor goes
};

/// Waits for the service (wall time) and calls it; false if it never appeared or the call failed.
template <typename S>
bool callService(const std::string& name, S& service, double timeout_s = 10.0) {
  if (!ros::service::waitForService(name, ros::Duration(timeout_s))) {
    ADD_FAILURE() << "service " << name << " did not appear within " << timeout_s << " s";
    return false;
  }
  if (!ros::service::call(name, service)) {
    ADD_FAILURE() << "call to " << name << " failed (callback returned false or the node died)";
    return false;
  }
  return true;
}

/// Waits until `publisher` has at least `count` subscribers, so the next message is not lost.
inline bool waitForSubscribers(const ros::Publisher& publisher, std::uint32_t count, double timeout_s) {
  return waitUntil([&] { return publisher.getNumSubscribers() >= count; }, timeout_s);
}

struct ProcessResult {
  int exit_code = -1;  ///< the process's exit status, or -1 if it did not exit normally
  std::string output;  ///< stdout and stderr together
};

/// Runs a shell command to completion and returns its exit code and combined output.
inline ProcessResult runProcess(const std::string& command) {
  ProcessResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  std::size_t read = 0;
  while ((read = fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, read);
  const int status = pclose(pipe);
  if (status != -1 && WIFEXITED(status)) result.exit_code = WEXITSTATUS(status);
  return result;
}

}  // namespace cloth_sim_test
