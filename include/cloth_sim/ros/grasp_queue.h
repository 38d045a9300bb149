// ~grasp commands between the thread that receives them and the spin thread that applies them, holding
// the last command of each grasp id. Under a flood (~grasp at 900 Hz beside ~wind at 10 kHz) the
// subscriber's own queue of 10 dropped messages while the spin thread was busy with a frame, and a
// dropped RELEASE left the cloth held for good (9 of 12 trials). Here a command is only ever replaced by a
// later command for the same id where that is what the simulation would have done with it anyway (a GRAB
// of a held id drags it, a RELEASE lets it go): a RELEASE replaces the id's pending commands, a GRAB its
// pending GRAB; a GRAB after a pending RELEASE is kept beside it (a new grasp, perhaps of another particle:
// alone it would have dragged the particle the id held). So at most a RELEASE and a GRAB wait per id, up to
// kMaxPendingIds commands at once (past that a flood of new ids makes room as below).
#pragma once

#include "cloth_sim/Grasp.h"

#include <cstddef>
#include <mutex>
#include <vector>

namespace cloth_sim {

class GraspCommandQueue {
 public:
  /// Distinct ids pending at most. The simulation holds at most 16 grasps, so this many ids between two
  /// drains means a peer is flooding ids; past it the oldest pending GRAB is dropped (counted in
  /// dropped()). When every pending command is a RELEASE, a new GRAB is dropped instead, and only a new
  /// RELEASE makes the oldest RELEASE give way.
  static constexpr std::size_t kMaxPendingIds = 1024;

  /// Any thread. Replaces the id's pending commands as above (the new one goes last). True when the queue
  /// was empty before: the caller then schedules a drain.
  bool push(const cloth_sim::Grasp::ConstPtr& command);
  /// Any thread: every pending command, oldest first, leaving the queue empty.
  std::vector<cloth_sim::Grasp::ConstPtr> take();
  /// Commands dropped for want of room since the last call (any thread).
  std::size_t takeDropped();

 private:
  std::mutex mutex_;
  std::vector<cloth_sim::Grasp::ConstPtr> pending_;  ///< at most a RELEASE then a GRAB per id, in arrival order
  std::size_t dropped_ = 0;
};

}  // namespace cloth_sim
