// What both sides of cloth_bench report the same way: per-frame time statistics and peak memory.
#pragma once

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

namespace cloth_sim::bench {

/// Mean, median and 99th percentile of per-frame wall times, ms; empty when no frame was timed.
struct FrameTimings {
  std::optional<double> mean_ms, p50_ms, p99_ms;
};

/// Nearest-rank percentile of sorted, non-empty values.
inline double percentile(const std::vector<double>& sorted, double fraction) {
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(sorted.size())));
  return sorted[std::min(sorted.size(), std::max<std::size_t>(rank, 1)) - 1];
}

inline FrameTimings summarizeFrameTimes(std::vector<double> frame_ms) {
  constexpr double kMedianFraction = 0.50;
  constexpr double kP99Fraction = 0.99;
  FrameTimings timings;
  if (frame_ms.empty()) return timings;
  double total_ms = 0;
  for (double ms : frame_ms) total_ms += ms;
  timings.mean_ms = total_ms / static_cast<double>(frame_ms.size());
  std::sort(frame_ms.begin(), frame_ms.end());
  timings.p50_ms = percentile(frame_ms, kMedianFraction);
  timings.p99_ms = percentile(frame_ms, kP99Fraction);
  return timings;
}

/// Peak resident memory of this process so far, MiB.
inline double peakRssMb() {
  constexpr double kKibPerMib = 1024.0;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / kKibPerMib;  // ru_maxrss is in KiB on Linux
}

}  // namespace cloth_sim::bench
