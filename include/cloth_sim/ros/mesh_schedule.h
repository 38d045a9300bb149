// When a mesh marker is due in a stream of stamped cloth frames: at most `rate` meshes per second of the
// stamps, on average, and that many when frames come faster. cloth_node (its ~mesh) and cloth_viewer
// (meshes from ~state) both thin their frames with it. No ROS inside: stamps are seconds.
//
// Due times advance by whole periods from the first mesh, not from the last mesh's stamp. Measured from
// the last stamp instead, a frame a few microseconds early for its period waited for the next frame:
// cloth_viewer asked for 25 Hz drew 19.8 Hz from a 50 Hz ~state. And with a tolerance taken off the
// period to cure that, a rate between 33 and 50 Hz sent every frame: cloth_node asked for 40 Hz sent 50.
#pragma once

namespace cloth_sim {

class MeshSchedule {
 public:
  /// rate_hz > 0 and finite (the caller validates it).
  explicit MeshSchedule(double rate_hz) : period_s_(1.0 / rate_hz) {}

  /// Whether the frame stamped stamp_s gets a mesh; if so, it counts as sent. A frame up to early_s before
  /// its due time counts as on time (stamps jitter: half a frame period is the callers' choice), which
  /// shifts the next due times by nothing. The first frame is due, and so is one whose stamp lies before
  /// the last mesh's (time went back: a looping /clock or bag) or a period or more past its due time (the
  /// frames stopped or came slower than the rate): the schedule then starts again from it, rather than
  /// catching up with a burst. A stamp that is not finite is never due.
  bool due(double stamp_s, double early_s);
  /// The next frame is due whatever its stamp, and the schedule starts again from it: the cloth changed
  /// while time stood still (a reset, a loaded state or a ~step under a held /clock), and a mesh of
  /// that stamp was already sent.
  void restart() { started_ = false; }

 private:
  double period_s_;
  bool started_ = false;
  double next_due_s_ = 0.0;  ///< when the next mesh is due
  double last_sent_s_ = 0.0;  ///< the stamp of the last mesh
};

}  // namespace cloth_sim
