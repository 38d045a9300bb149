#include "cloth_sim/ros/grasp_queue.h"

#include <algorithm>

namespace cloth_sim {

bool GraspCommandQueue::push(const cloth_sim::Grasp::ConstPtr& command) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool was_empty = pending_.empty();
  const auto of_id = [&](const cloth_sim::Grasp::ConstPtr& held) { return held->id == command->id; };
  const auto last_of_id = std::find_if(pending_.rbegin(), pending_.rend(), of_id);
  if (last_of_id != pending_.rend()) {
    if (command->action == cloth_sim::Grasp::RELEASE) {
      // A release ends whatever the id's pending commands would have done.
      pending_.erase(std::remove_if(pending_.begin(), pending_.end(), of_id), pending_.end());
    } else if ((*last_of_id)->action != cloth_sim::Grasp::RELEASE) {
      pending_.erase(std::next(last_of_id).base());  // a drag: the newer target replaces the older
    }
    // A GRAB after a pending RELEASE of its id is a new grasp, perhaps of another particle: both stay, in
    // order (the GRAB alone would drag the particle the id held before, not take its own).
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
