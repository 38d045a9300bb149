#include "cloth_sim/ros/frame_budget.h"

#include "cloth_sim/core/constants.h"

#include <cstdio>

namespace cloth_sim {

namespace {
using core::kMillisecondsPerSecond;
constexpr std::size_t kMessageLength = 160;
}  // namespace

void FrameBudget::addFrame(double cost_ms) {
  cost_sum_ms_ += cost_ms;
  ++frames_;
}

void FrameBudget::addStateMessage() { ++state_messages_; }

FrameBudget::Verdict FrameBudget::judge(double frame_period_s, double window_wall_s) const {
  Verdict verdict;
  verdict.frames = frames_;
  verdict.budget_ms = frame_period_s * kMillisecondsPerSecond;
  verdict.mean_step_cost_ms = frames_ > 0 ? cost_sum_ms_ / frames_ : 0.0;
  verdict.state_rate_hz = window_wall_s > 0.0 ? state_messages_ / window_wall_s : 0.0;
  // A paused node advances nothing and is within any budget.
  verdict.over_budget = frames_ > 0 && verdict.mean_step_cost_ms > verdict.budget_ms;
  if (verdict.over_budget) {
    char text[kMessageLength];
    std::snprintf(text, sizeof text, "physics %.1f ms/frame > %.1f ms budget (%.0f Hz): ~state at %.1f Hz",
                  verdict.mean_step_cost_ms, verdict.budget_ms, 1.0 / frame_period_s, verdict.state_rate_hz);
    verdict.message = text;
  }
  return verdict;
}

void FrameBudget::clear() {
  cost_sum_ms_ = 0.0;
  frames_ = 0;
  state_messages_ = 0;
}

}  // namespace cloth_sim
