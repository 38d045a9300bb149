#include "cloth_sim/ros/grasp_queue.h"

#include <algorithm>

namespace cloth_sim {

bool GraspCommandQueue::push(const cloth_sim::Grasp::ConstPtr& command) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool was_empty = pending_.empty();
  const auto same_id = std::find_if(pending_.begin(), pending_.end(),
                                    [&](const cloth_sim::Grasp::ConstPtr& held) { return held->id == command->id; });
  if (same_id != pending_.end()) {
    pending_.erase(same_id);
  } else if (pending_.size() >= kMaxPendingIds) {
    ++dropped_;
    const auto oldest_grab = std::find_if(pending_.begin(), pending_.end(), [](const cloth_sim::Grasp::ConstPtr& held) {
      return held->action != cloth_sim::Grasp::RELEASE;
    });
    if (oldest_grab != pending_.end()) {
      pending_.erase(oldest_grab);
    } else if (command->action != cloth_sim::Grasp::RELEASE) {
      return was_empty;  // every pending command lets a hand go: the new GRAB gives way, not one of them
    } else {
      pending_.erase(pending_.begin());
    }
  }
  pending_.push_back(command);
  return was_empty;
}

std::vector<cloth_sim::Grasp::ConstPtr> GraspCommandQueue::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<cloth_sim::Grasp::ConstPtr> taken;
  taken.swap(pending_);
  return taken;
}

std::size_t GraspCommandQueue::takeDropped() {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::size_t dropped = dropped_;
  dropped_ = 0;
  return dropped;
}

}  // namespace cloth_sim
