// MeshSchedule on its own (no master): cloth_node's ~mesh and cloth_viewer's mesh come at ~mesh_rate on
// average, at most, whatever the frames' stamps jitter, and come again at once after time went back or
// the frames stopped.
#include "cloth_sim/ros/mesh_schedule.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace cloth_sim {
namespace {

constexpr double kFramePeriod_s = 0.02;  // 50 Hz
constexpr double kEarly_s = 0.5 * kFramePeriod_s;
/// Stamps of wall-clock frames jitter by tens of microseconds (measured on cloth_node's ~state).
constexpr double kJitter_s = 50e-6;

/// The stamps of the frames that get a mesh, of `frames` frames from t0_s on at the frame period, each
/// off its exact time by up to jitter_s.
std::vector<double> meshStamps(MeshSchedule& schedule, double t0_s, int frames, double jitter_s, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> jitter(-jitter_s, jitter_s);
  std::vector<double> sent;
  for (int k = 0; k < frames; ++k) {
    const double stamp_s = t0_s + k * kFramePeriod_s + jitter(random);
    if (schedule.due(stamp_s, kEarly_s)) sent.push_back(stamp_s);
  }
  return sent;
}

TEST(MeshSchedule, MeshesComeAtTheRateOnAverageWhateverTheStampsJitter) {
  // 10 s of 50 Hz frames: at 25 Hz the old viewer drew 19.8 (a frame microseconds early waited for the
  // next), at 40 Hz the old node sent all 50.
  for (const double rate_hz : {10.0, 25.0, 30.0, 40.0, 50.0}) {
    for (unsigned seed = 1; seed <= 5; ++seed) {
      MeshSchedule schedule(rate_hz);
      const std::vector<double> sent = meshStamps(schedule, 1000.0, 500, kJitter_s, seed);
      EXPECT_NEAR(static_cast<double>(sent.size()), 10.0 * rate_hz, 1.0) << rate_hz << " Hz, seed " << seed;
      // Never two meshes closer than a frame, and none more than a period plus a frame after the last.
      for (std::size_t k = 1; k < sent.size(); ++k) {
        EXPECT_GT(sent[k] - sent[k - 1], kFramePeriod_s - 2.0 * kJitter_s - 1e-12) << rate_hz << " Hz";
        EXPECT_LT(sent[k] - sent[k - 1], 1.0 / rate_hz + kFramePeriod_s + 2.0 * kJitter_s) << rate_hz << " Hz";
      }
    }
  }
}

TEST(MeshSchedule, AWholeNumberOfFramesPerMeshComesEvenlySpaced) {
  // 25 Hz from 50 Hz frames: every second frame, exactly, jitter or not.
  MeshSchedule schedule(25.0);
  const std::vector<double> sent = meshStamps(schedule, 5.0, 200, kJitter_s, 7);
  ASSERT_EQ(sent.size(), 100u);
  for (std::size_t k = 1; k < sent.size(); ++k) EXPECT_NEAR(sent[k] - sent[k - 1], 2.0 * kFramePeriod_s, 2.0 * kJitter_s);
}

TEST(MeshSchedule, EveryFrameGetsAMeshWhenTheRateIsAtOrAboveTheFrames) {
  for (const double rate_hz : {50.0, 100.0, 1000.0}) {
    MeshSchedule schedule(rate_hz);
    EXPECT_EQ(meshStamps(schedule, 0.0, 300, kJitter_s, 3).size(), 300u) << rate_hz << " Hz";
  }
  // Frames slower than the rate (a slow node: 7 Hz) each get one too.
  MeshSchedule schedule(25.0);
  for (int k = 0; k < 20; ++k) EXPECT_TRUE(schedule.due(k / 7.0, kEarly_s)) << k;
}

TEST(MeshSchedule, TimeGoingBackMakesAMeshDueAtOnce) {
  MeshSchedule schedule(10.0);
  EXPECT_TRUE(schedule.due(100.0, kEarly_s));
  EXPECT_FALSE(schedule.due(100.02, kEarly_s));
  EXPECT_TRUE(schedule.due(3.0, kEarly_s));  // a looping bag or /clock starts again
  EXPECT_FALSE(schedule.due(3.02, kEarly_s));
  EXPECT_TRUE(schedule.due(3.1, kEarly_s));
}

TEST(MeshSchedule, AStampThatIsNotFiniteIsNeverDueAndChangesNothing) {
  MeshSchedule schedule(25.0);
  EXPECT_TRUE(schedule.due(10.0, kEarly_s));
  EXPECT_FALSE(schedule.due(std::nan(""), kEarly_s));
  EXPECT_FALSE(schedule.due(std::numeric_limits<double>::infinity(), kEarly_s));
  EXPECT_FALSE(schedule.due(10.02, kEarly_s));
  EXPECT_TRUE(schedule.due(10.04, kEarly_s));
  EXPECT_TRUE(schedule.due(2.0, kEarly_s));  // time going back is still noticed
}

TEST(MeshSchedule, AfterFramesStopTheScheduleStartsAgainWithoutABurst) {
  MeshSchedule schedule(25.0);
  meshStamps(schedule, 0.0, 50, 0.0, 1);  // 1 s, then nothing for 2 s
  const std::vector<double> sent = meshStamps(schedule, 3.0, 50, 0.0, 1);
  ASSERT_EQ(sent.size(), 25u);
  EXPECT_DOUBLE_EQ(sent.front(), 3.0);  // the first frame after the gap
  EXPECT_NEAR(sent[1] - sent[0], 0.04, 1e-12);  // then the rate, not the missed meshes
}

TEST(MeshSchedule, ARestartMakesTheNextFrameDueAtTheSameStamp) {
  cloth_sim::MeshSchedule schedule(25.0);
  EXPECT_TRUE(schedule.due(1.0, 0.0));
  EXPECT_FALSE(schedule.due(1.0, 0.0)) << "one mesh per stamp";
  schedule.restart();
  EXPECT_TRUE(schedule.due(1.0, 0.0)) << "the cloth changed at the same stamp";
  EXPECT_FALSE(schedule.due(1.02, 0.0)) << "and the rate counts from it";
  EXPECT_TRUE(schedule.due(1.04, 0.0));
}

}  // namespace
}  // namespace cloth_sim
