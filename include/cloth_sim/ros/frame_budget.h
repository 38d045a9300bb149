// Whether the physics fits in the frame: cloth_node's diagnostics say so when it does not, with how fast
// ~state then really comes (issue 13: every scene publishes at 50 Hz where the physics allows, and says
// which and why where it does not). Counts one diagnostics window at a time; no ROS inside.
#pragma once

#include <string>

namespace cloth_sim {

class FrameBudget {
 public:
  /// What one window found.
  struct Verdict {
    double mean_step_cost_ms = 0.0;  ///< wall time per frame advanced, mean over the window
    double budget_ms = 0.0;          ///< the frame period: the most a frame may cost to keep the frame rate
    double state_rate_hz = 0.0;      ///< ~state messages (one per frame, or per tick while paused) per wall second
    int frames = 0;                  ///< frames advanced in the window
    bool over_budget = false;        ///< frames were advanced and cost more than the budget on average
    /// e.g. "physics 35.2 ms/frame > 20.0 ms budget (50 Hz): ~state at 28.4 Hz"; empty when within it.
    std::string message;
  };

  /// One frame advanced, costing `cost_ms` of wall time.
  void addFrame(double cost_ms);
  /// One ~state message due (sent if anyone subscribes).
  void addStateMessage();
  /// The window's verdict for frames due every `frame_period_s`, over `window_wall_s` of wall time.
  Verdict judge(double frame_period_s, double window_wall_s) const;
  /// Starts a new window.
  void clear();

 private:
  double cost_sum_ms_ = 0.0;
  int frames_ = 0;
  int state_messages_ = 0;
};

}  // namespace cloth_sim
