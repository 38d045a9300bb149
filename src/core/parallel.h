// Internal to the core library (compiled with OpenMP): loops over particles on all cores above a size,
// and sums that give the same bits whatever the number of threads.
#pragma once

#include <Eigen/Core>

#include <algorithm>
#include <vector>

namespace cloth_sim::core {

/// Particles from which loops may run on several threads (when the options ask for more than one):
/// below it, starting the threads costs more than the share of work they take.
constexpr Eigen::Index kParallelParticles = 4096;
/// Reductions add up partial sums over fixed chunks of this many particles, in chunk order.
constexpr Eigen::Index kReductionChunk = 1024;

/// True when a loop over `count` particles should use `threads` threads.
inline bool runsInParallel(Eigen::Index count, int threads) { return threads > 1 && count >= kParallelParticles; }

/// Calls body(begin, end) for consecutive chunks covering [0, count), on `threads` threads from
/// kParallelParticles up.
template <typename Body>
void forEachChunk(Eigen::Index count, int threads, Body body) {
  const Eigen::Index chunks = (count + kReductionChunk - 1) / kReductionChunk;
#pragma omp parallel for schedule(static) num_threads(threads) if (runsInParallel(count, threads))
  for (Eigen::Index chunk = 0; chunk < chunks; ++chunk) {
    body(chunk * kReductionChunk, std::min(count, (chunk + 1) * kReductionChunk));
  }
}

/// Sum of chunk_sum(begin, end) over the chunks of [0, count), added in chunk order: chunk boundaries do
/// not depend on the threads, so neither do the bits of the result.
template <typename ChunkSum>
double deterministicSum(Eigen::Index count, int threads, ChunkSum chunk_sum, std::vector<double>& partial) {
  const Eigen::Index chunks = (count + kReductionChunk - 1) / kReductionChunk;
  partial.assign(static_cast<std::size_t>(chunks), 0.0);
  forEachChunk(count, threads, [&](Eigen::Index begin, Eigen::Index end) {
    partial[static_cast<std::size_t>(begin / kReductionChunk)] = chunk_sum(begin, end);
  });
  double sum = 0.0;
  for (double value : partial) sum += value;
  return sum;
}

}  // namespace cloth_sim::core
