// Time differences that cannot throw. ros::Time minus ros::Time is a ros::Duration, whose seconds are an
// int32: beyond +-2^31 s it throws std::runtime_error, and an exception out of a callback ends the node. A
// ros::Time's seconds are a uint32 (to about 4.29e9 s), so a /clock at 2^31 s or later, or one that leaps
// that far, puts any difference with a zero or an old time out of a Duration's range.
#pragma once

#include <ros/time.h>

#include <cstdint>

namespace cloth_sim {

/// later - earlier in seconds (negative when `later` is the earlier), for any two ros::Times. Where a
/// ros::Duration holds the difference, bit for bit what (later - earlier).toSec() gives.
inline double secondsBetween(const ros::Time& earlier, const ros::Time& later) {
  constexpr std::int64_t kNanosecondsPerSecond = 1000000000;
  // Both at most 2^32 s in nanoseconds (below 2^62): the difference fits an int64.
  const std::int64_t difference_ns =
      static_cast<std::int64_t>(later.toNSec()) - static_cast<std::int64_t>(earlier.toNSec());
  // Whole seconds rounded down and the nanoseconds in [0, 1e9), summed as ros::Duration::toSec sums them.
  std::int64_t seconds = difference_ns / kNanosecondsPerSecond;
  std::int64_t nanoseconds = difference_ns % kNanosecondsPerSecond;
  if (nanoseconds < 0) {
    nanoseconds += kNanosecondsPerSecond;
    --seconds;
  }
  return static_cast<double>(seconds) + 1e-9 * static_cast<double>(nanoseconds);
}

}  // namespace cloth_sim
