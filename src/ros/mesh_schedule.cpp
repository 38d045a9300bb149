#include "cloth_sim/ros/mesh_schedule.h"

#include <cmath>

namespace cloth_sim {

bool MeshSchedule::due(double stamp_s, double early_s) {
  if (!std::isfinite(stamp_s)) return false;  // no time to schedule by (and it would poison the next tests)
  const bool restart = !started_ || stamp_s < last_sent_s_ || stamp_s >= next_due_s_ + period_s_;
  if (!restart && stamp_s < next_due_s_ - early_s) return false;
  next_due_s_ = restart ? stamp_s + period_s_ : next_due_s_ + period_s_;
  last_sent_s_ = stamp_s;
  started_ = true;
  return true;
}

}  // namespace cloth_sim
