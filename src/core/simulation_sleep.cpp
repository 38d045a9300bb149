// Simulation's sleep (SceneOptions::sleep_speed_m_per_s): whether anything drives the cloth, the
// fingerprint of its inputs, the calm frames before it sleeps and the frames it sleeps through.
#include "cloth_sim/core/simulation.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>

namespace cloth_sim::core {

namespace {

/// FNV-1a over raw bytes (64-bit): equal inputs give equal fingerprints on one machine, which is all the
/// sleep test needs (it is kept in the state file beside the state it belongs to).
class Fingerprint {
 public:
  void add(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) hash_ = (hash_ ^ bytes[i]) * kPrime;
  }
  template <typename T>
  void add(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    add(&value, sizeof(T));
  }
  /// A count, as 64 bits whatever the platform's size_t (the fingerprint is in the state file).
  void addCount(std::size_t count) { add(static_cast<std::uint64_t>(count)); }
  /// Its shape and its values (any plain matrix: no copy on the per-frame path).
  template <typename Derived>
  void addMatrix(const Eigen::PlainObjectBase<Derived>& values) {
    addCount(static_cast<std::size_t>(values.rows()));
    addCount(static_cast<std::size_t>(values.cols()));
    add(values.data(), sizeof(double) * static_cast<std::size_t>(values.size()));
  }
  std::uint64_t value() const { return hash_; }

 private:
  static constexpr std::uint64_t kOffsetBasis = 14695981039346656037ULL;
  static constexpr std::uint64_t kPrime = 1099511628211ULL;
  std::uint64_t hash_ = kOffsetBasis;
};

}  // namespace

bool Simulation::isDriven() const {
  const Kinematics& kinematics = force_model_.kinematics();
  for (std::size_t body = 0; body < kinematics.bodies().size(); ++body) {
    if (kinematics.peakSpeed_m_per_s(body, state_.time_s) > kHeldStillSpeed_m_per_s) return true;
  }
  return options_.wind_enabled && options_.wind.gust_amplitude != 0.0 && !inputs_.wind_m_per_s.isZero(0.0);
}

std::uint64_t Simulation::driveFingerprint() const {
  Fingerprint print;
  print.add(options_.wind_enabled);
  print.addMatrix(inputs_.wind_m_per_s);
  for (const Grasp& grasp : inputs_.grasps) {
    print.add(grasp.id);
    print.add(grasp.particle);
    print.addMatrix(grasp.target_m);
    print.add(grasp.stiffness_N_per_m);
    print.add(grasp.damping_N_s_per_m);
    print.addMatrix(grasp.extra_force_N);
  }
  print.addCount(inputs_.pins.size());
  print.add(inputs_.pins.data(), sizeof(int) * inputs_.pins.size());
  print.addMatrix(inputs_.pin_anchors_m);
  print.addMatrix(inputs_.pin_travel_m);
  for (const Gripper& gripper : inputs_.grippers) {
    print.add(gripper.id);
    print.addCount(gripper.particles.size());
    print.add(gripper.particles.data(), sizeof(int) * gripper.particles.size());
    print.addMatrix(gripper.offsets_m);
    print.add(gripper.max_force_N);
  }
  // A link's first pose places it without sweeping it there: only the change of `seen` says it came.
  for (const FrameColliderTrack& link : inputs_.frame_colliders) print.add(link.seen);
  return print.value();
}

int Simulation::sleepAfterFrames(const SceneOptions& options) {
  return std::max(1, static_cast<int>(std::ceil(SceneOptions::kSleepAfter_s * options.frame_rate_hz)));
}

double Simulation::sleepAllowance_m(const SceneOptions& options) {
  return options.sleep_speed_m_per_s * SceneOptions::kSleepAfter_s;
}

void Simulation::countCalmFrame(bool still_inputs, double step_m) {
  const int asleep_from = sleepAfterFrames(options_);
  bool calm = options_.sleep_speed_m_per_s > 0.0 && still_inputs;
  if (calm) {
    const Eigen::Matrix3Xd& anchor = memory_.calm_frames > 0 ? memory_.calm_anchor_m : frame_start_.positions_m;
    calm = (state_.positions_m - anchor).colwise().norm().maxCoeff() <= sleepAllowance_m(options_);
  }
  if (calm && memory_.calm_frames >= asleep_from) {
    calm = step_m <= memory_.calm_largest_step_m + options_.sleep_speed_m_per_s * options_.frameDuration_s();
  }
  if (!calm) {
    memory_.forgetCalm();
    return;
  }
  if (memory_.calm_frames == 0) memory_.calm_anchor_m = frame_start_.positions_m;
  if (memory_.calm_frames >= asleep_from / 2 && memory_.calm_frames < asleep_from) {
    memory_.calm_largest_step_m = std::max(memory_.calm_largest_step_m, step_m);
  }
  memory_.calm_frames = std::min(memory_.calm_frames + 1, asleep_from);
}

int Simulation::sleepCheckFrames(const SceneOptions& options) {
  return std::max(1, static_cast<int>(std::ceil(SceneOptions::kSleepCheckPeriod_s * options.frame_rate_hz)));
}

bool Simulation::restsAsleep(bool driven, std::uint64_t drive) const {
  return options_.sleep_speed_m_per_s > 0.0 && memory_.calm_frames >= sleepAfterFrames(options_) && !driven &&
         drive == memory_.drive_fingerprint;
}

bool Simulation::sleepsThrough(bool driven, std::uint64_t drive) const {
  // By frame number, so that a restored run checks on the same frames.
  const bool check_frame = (state_.frame + 1) % static_cast<std::uint64_t>(sleepCheckFrames(options_)) == 0;
  return restsAsleep(driven, drive) && !check_frame;
}

void Simulation::sleepThroughFrame(FrameReport* report) {
  // The cloth stood still for sleepAfterFrames frames under the same inputs, with nothing moving it:
  // no particle got further than sleepAllowance_m from where it was when they began, so this frame is not
  // computed and only time goes on. The substeps `auto` remembers, the gripper wrenches and the energies
  // stay those of the last computed frame, whose state this still is.
  report->asleep = true;
  report->substeps_used = 0;
  report->max_strain = energy_cache_valid_ ? cached_strain_ : maxStructuralStrain();
  state_.time_s += options_.frameDuration_s();
  ++state_.frame;
}

}  // namespace cloth_sim::core
