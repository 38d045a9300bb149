// Kinematics: everything that moves the cloth by prescription rather than by force, in one shape.
//
// A Body is something with a pose over time (world frame): the hook a pin hangs on, a swinging sphere,
// later a gripper or a robot link. Its motion is either a ScriptedMotion (a closed form at any instant:
// the scenes' A sin(2 pi t / T) swings, drift and smoothstep travel) or a PoseTrack (a pose at the start
// and at the end of one frame, e.g. sampled from tf, interpolated in between). An Attachment holds
// particles rigidly in a body's frame: particle i sits at pose.position + pose.orientation * offset_i,
// with the velocity v + omega x (pose.orientation * offset_i). Kinematics gathers the bodies and the
// attachments and answers what the rest of the core asks of them: which particles are constrained, where
// they must be at a time (the implicit solver's filter), how fast each body can go (the guard's energy
// budget).
//
// Today's scenes are derived from their options and inputs (Kinematics::setScene): one body per pin's
// hook, carrying its particle at offset zero, and one body per sphere collider. The results are the same
// bits as the closed forms these bodies replace.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace cloth_sim::core {

struct SceneOptions;
struct ClothInputs;
struct ClothState;

/// Peak rate of the smoothstep s(u) = 3u^2 - 2u^3 that carries pins to their hooks, per unit of u: s'(u) =
/// 6u(1 - u) peaks at u = 1/2 with 1.5. The one home of this number (options' validation and the guard's
/// budget both ask ScriptedMotion).
inline constexpr double kSmoothstepPeakRate = 1.5;

/// Peak speed of a swing A sin(2 pi t / T), m/s: |A| 2 pi / T; 0 for a zero amplitude whatever the period.
/// The one home of the swing speed.
double swingPeakSpeed_m_per_s(const Eigen::Vector3d& amplitude_m, double period_s);

/// A rigid pose, world frame: a point p in the body's frame is at position_m + orientation * p.
struct Pose {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< unit quaternion

  /// Where a point given in the body's frame is, world frame, m.
  Eigen::Vector3d transform(const Eigen::Vector3d& local_m) const { return position_m + orientation * local_m; }
};

/// A stored orientation is a unit quaternion to within this (they are normalised when they come in).
inline constexpr double kUnitQuaternionTolerance = 1e-6;

/// A pose a gripper, a frame collider or a state file may hold: finite, at most max_reach_m from the
/// origin, its orientation a unit quaternion.
bool isFinitePose(const Pose& pose, double max_reach_m);

/// A rigid body's velocity, world frame: the origin's linear velocity and the angular velocity.
struct Twist {
  Eigen::Vector3d linear_m_per_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_rad_per_s = Eigen::Vector3d::Zero();

  /// Velocity of a point lever_m away from the body's origin (world frame): v + omega x lever.
  Eigen::Vector3d pointVelocity(const Eigen::Vector3d& lever_m) const {
    return linear_m_per_s + angular_rad_per_s.cross(lever_m);
  }
};

/// A body's motion over one frame of duration_s from start_time_s: the origin moves on the straight line
/// from start to end at constant speed, the orientation turns at constant angular velocity about one world
/// axis (spherical linear interpolation, the shorter way round). So twist() is the exact derivative of at().
struct PoseTrack {
  Pose start;
  Pose end;
  double start_time_s = 0.0;
  double duration_s = 1.0;  ///< > 0

  /// The pose at fraction s of the frame (0: start, 1: end; clamped to [0, 1]).
  Pose at(double s) const;
  /// The pose at time_s (clamped to the frame).
  Pose atTime(double time_s) const { return at((time_s - start_time_s) / duration_s); }
  /// The constant twist that carries start to end over the frame.
  Twist twist() const;
};

/// A closed-form translation (no rotation): the scenes' scripted motions.
///   position(t) = origin + velocity t + swing_amplitude sin(2 pi t / swing_period) + remaining(t) travel
/// with remaining(t) = 1 - s(t / travel_time) the smoothstep share of the travel still to go (0 from
/// travel_time on, or when travel_time is 0): the body starts `travel` away from its path and arrives on it
/// with zero speed. A pin's hook: origin = the hook, a swing, a travel. A sphere: origin = c0, a drift, a swing.
struct ScriptedMotion {
  Eigen::Vector3d origin_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_m_per_s = Eigen::Vector3d::Zero();
  Eigen::Vector3d swing_amplitude_m = Eigen::Vector3d::Zero();
  double swing_period_s = 1.0;  ///< > 0
  Eigen::Vector3d travel_m = Eigen::Vector3d::Zero();
  double travel_time_s = 0.0;  ///< 0: no travel

  /// The share of the travel still to go at time_s, and its rate of change, 1/s.
  struct TravelShare {
    double remaining = 0.0;
    double rate_per_s = 0.0;
  };
  TravelShare travelShare(double time_s) const;
  Eigen::Vector3d positionAt(double time_s) const;
  Eigen::Vector3d velocityAt(double time_s) const;
  /// The swing's displacement at time_s alone, m (what a pin let go of keeps adding to its new hook).
  Eigen::Vector3d swingAt(double time_s) const;
  /// An upper bound on the speed from time_s on, m/s: |velocity| + the swing's peak + the travel's peak
  /// (kSmoothstepPeakRate |travel| / travel_time, while the travel lasts).
  double peakSpeed_m_per_s(double from_time_s) const;
};

/// Something with a pose over time that moves the cloth by prescription.
struct Body {
  using Motion = std::variant<ScriptedMotion, PoseTrack>;

  std::string name;  ///< for messages: "pin 19", "sphere 0"
  Motion motion;

  Pose poseAt(double time_s) const;
  Twist twistAt(double time_s) const;
  /// An upper bound on the speed of the body's origin from time_s to the end of the frame (a track: its
  /// linear speed), m/s; a held particle away from the origin adds |omega| times its lever (Kinematics).
  double peakSpeed_m_per_s(double time_s) const;
};

/// Particles held rigidly in a body's frame: particle particles[k] sits at offsets_m.col(k) in it.
struct Attachment {
  std::size_t body = 0;  ///< index into Kinematics::bodies()
  std::vector<int> particles;
  Eigen::Matrix3Xd offsets_m;  ///< 3 x particles.size(), the body's frame, m
};

class Kinematics {
 public:
  /// Adds a body; returns its index.
  std::size_t addBody(Body body);
  /// Holds particles rigidly on a body (its index must exist; particles must not be held already).
  void attach(Attachment attachment);
  void clear();

  const std::vector<Body>& bodies() const { return bodies_; }

  /// The motion of the hook of pin inputs.pins[pin]: the hook inputs.pin_anchors_m.col(pin), the scene's
  /// swing (pin_motion_amplitude, pin_motion_period) and the pin's travel over pin_travel_time.
  static ScriptedMotion hookMotion(const SceneOptions& options, const ClothInputs& inputs, std::size_t pin);
  /// Rebuilds the bodies of today's scenes from their options and inputs: a hook per pin that no grasp
  /// holds (the scene's swing and travel, the hook from inputs.pin_anchors_m), holding its particle at
  /// offset zero, then a body per sphere collider (in options.colliders.spheres order, see sphereBody),
  /// then a body per gripper holding particles (inputs.grippers order), moving on the gripper's track.
  void setScene(const SceneOptions& options, const ClothInputs& inputs);
  /// The body of options.colliders.spheres[sphere] after setScene.
  std::size_t sphereBody(std::size_t sphere) const { return sphere_bodies_[sphere]; }
  /// The bodies of the frame colliders seen so far, with the index of their collider in
  /// options.colliders.frames (after setScene, which adds them after the grippers).
  const std::vector<std::pair<std::size_t, std::size_t>>& frameColliderBodies() const { return frame_collider_bodies_; }

  /// Sets inverse_mass_per_kg to 0 on every held particle (the constrained mask); others untouched.
  void maskConstrained(Eigen::VectorXd& inverse_mass_per_kg) const;
  /// Writes where the held particles must be at time_s into their columns; others untouched.
  void prescribedPositions(double time_s, Eigen::Matrix3Xd& positions_m) const;
  /// Puts every held particle where its body holds it at time_s, with the velocity of that point of the body.
  void enforce(double time_s, ClothState& state) const;
  /// An upper bound on how fast the particles body `body` holds (or its origin, if it holds none) move
  /// from time_s to the end of the frame, m/s.
  double peakSpeed_m_per_s(std::size_t body, double time_s) const;
  /// Particles body `body` holds.
  int heldParticles(std::size_t body) const;

 private:
  std::vector<Body> bodies_;
  std::vector<Attachment> attachments_;
  std::vector<std::size_t> sphere_bodies_;
  std::vector<std::pair<std::size_t, std::size_t>> frame_collider_bodies_;  ///< {collider, body}
};

}  // namespace cloth_sim::core
