#!/usr/bin/python3
"""A rospy client for cloth_node: blow wind, grab the bottom-left corner, drag it round a circle, let go.

Start a simulator first (roscore; rosrun cloth_sim cloth_node), then:

    examples/cloth_client.py                      # or: rosrun cloth_sim cloth_client.py
    examples/cloth_client.py --node /cloth_node --wind 3.0 --seconds 2.0

Every wait has a deadline and ends the script with a message that says what was missing, so a
mistyped namespace fails in seconds instead of hanging.
"""

import argparse
import math
import sys
import threading
import time

import rospy
from geometry_msgs.msg import Point, Vector3, Vector3Stamped
from visualization_msgs.msg import Marker

from cloth_sim.msg import ClothState, Grasp

# How long to wait for the node's first messages and for our publishers to be connected (wall time).
CONNECT_TIMEOUT_S = 10.0
# How long to wait for any single later state (the node publishes one every 0.02 s).
STATE_TIMEOUT_S = 5.0
# Let the wind act before grabbing, so its effect on the corner is visible on its own.
WIND_SETTLE_S = 1.0
# After the last target: a short hold to see the corner settle, then a short look after the release.
HOLD_S = 0.5
AFTER_RELEASE_S = 0.5
# Time for rospy's sender threads to deliver the last messages when we exit early.
FLUSH_S = 0.3
# Targets along the drag path (published evenly over --seconds).
DRAG_STEPS = 20
# Radius of the circle the corner is dragged around, m (it starts and ends where the corner was).
DRAG_RADIUS_M = 0.2
# Grasp spring, N/m. 100 N/m keeps the corner within about 2 cm of a hand moving at 0.6 m/s (the
# node's default, grasp_stiffness 50 N/m: about 2.5 cm). Stiffer is not better: the grasp (with the
# node's grasp_damping) stops a corner that flaps in the wind within one frame, and the stiffer the
# spring the harder that snap stretches the cloth above it: about 36 % at 100 N/m, past the node's
# 50 % "over-stretched" warning from about 300 N/m.
GRASP_STIFFNESS_N_PER_M = 100.0
# Any id in [0, 16) works; several ids can hold the cloth at once.
GRASP_ID = 1


class ClientError(Exception):
    """A wait ran past its deadline; the message says what to check."""


class StateMonitor:
    """Keeps the latest ~state message and lets the caller wait for one that satisfies a condition.

    rospy calls the callback on its own thread, hence the condition variable.
    """

    def __init__(self, topic):
        self._topic = topic
        self._latest = None
        self._changed = threading.Condition()
        self._subscriber = rospy.Subscriber(topic, ClothState, self._on_state, queue_size=1)

    def _on_state(self, state):
        with self._changed:
            self._latest = state
            self._changed.notify_all()

    def wait_for(self, predicate, timeout_s, what):
        """The first state (the latest one included) for which predicate holds; ClientError on timeout."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while self._latest is None or not predicate(self._latest):
                if rospy.is_shutdown():
                    raise rospy.ROSInterruptException("shut down while waiting")
                remaining_s = deadline - time.monotonic()
                if remaining_s <= 0.0:
                    raise ClientError(f"no {what} on {self._topic} within {timeout_s:.0f} s")
                self._changed.wait(min(remaining_s, 0.1))  # wake up now and then to notice shutdown
            return self._latest

    def newer_than(self, state, timeout_s=STATE_TIMEOUT_S):
        """The first state of a later frame than `state`'s."""
        # A paused node republishes the same frame: that is not a new reading.
        return self.wait_for(lambda s: s.frame != state.frame or s.sim_time != state.sim_time,
                             timeout_s, f"state after frame {state.frame} (is the node paused?)")


def wait_for_connection(publisher, timeout_s=CONNECT_TIMEOUT_S):
    """Waits until the node subscribes to `publisher`.

    A message published right after advertise() goes nowhere: the TCP connection to the subscriber is
    made asynchronously, and rospy drops messages that have no connection yet.
    """
    deadline = time.monotonic() + timeout_s
    while publisher.get_num_connections() == 0:
        if rospy.is_shutdown():
            raise rospy.ROSInterruptException("shut down while waiting")
        if time.monotonic() > deadline:
            raise ClientError(f"nobody subscribed to {publisher.resolved_name} within {timeout_s:.0f} s")
        time.sleep(0.01)


def distance_m(a, b):
    return math.sqrt((a.x - b.x) ** 2 + (a.y - b.y) ** 2 + (a.z - b.z) ** 2)


def fmt(point):
    return f"({point.x:+.3f}, {point.y:+.3f}, {point.z:+.3f})"


def circle_target(start, step, steps, radius_m):
    """Target `step` of `steps` on a vertical circle through `start` (its lowest point), in the y-z plane.

    y-z is across the cloth's plane (the built-in scenes hang it in x-z), so the corner swings out of
    the cloth and back rather than into its neighbours. Step `steps` is back at `start`.
    """
    angle_rad = 2.0 * math.pi * step / steps
    return Point(x=start.x,
                 y=start.y + radius_m * math.sin(angle_rad),
                 z=start.z + radius_m * (1.0 - math.cos(angle_rad)))


def make_grasp(frame_id, action, particle, target):
    grasp = Grasp()
    grasp.header.stamp = rospy.Time.now()
    grasp.header.frame_id = frame_id  # the frame `target` is in
    grasp.id = GRASP_ID
    grasp.action = action
    grasp.particle = particle
    grasp.target = target
    grasp.stiffness = GRASP_STIFFNESS_N_PER_M
    return grasp  # grasp.force stays zero: the spring alone moves the corner


def make_wind(frame_id, wind_y_m_per_s):
    wind = Vector3Stamped()
    wind.header.stamp = rospy.Time.now()
    wind.header.frame_id = frame_id
    wind.vector = Vector3(x=0.0, y=wind_y_m_per_s, z=0.0)
    return wind


def release_and_calm(grasp_pub, wind_pub, frame_id, corner, grabbed):
    if grabbed:
        grasp_pub.publish(make_grasp(frame_id, Grasp.RELEASE, corner, Point()))
    wind_pub.publish(make_wind(frame_id, 0.0))


def run(node_ns, wind_m_per_s, drag_s):
    # 1. The node's first messages. wait_for_message subscribes only while it waits: cloth_node builds
    #    ~mesh only while someone listens, so this also checks that the mesh is being produced.
    mesh_topic = node_ns + "/mesh"
    try:
        mesh = rospy.wait_for_message(mesh_topic, Marker, timeout=CONNECT_TIMEOUT_S)
    except rospy.ROSException:
        raise ClientError(f"no Marker on {mesh_topic} within {CONNECT_TIMEOUT_S:.0f} s: is cloth_node "
                          f"running under {node_ns}, on this ROS_MASTER_URI? (rostopic list)") from None
    states = StateMonitor(node_ns + "/state")
    first = states.wait_for(lambda _: True, CONNECT_TIMEOUT_S, "ClothState")
    # Targets and wind are given in the node's own frame (frame_id "world" by default), so the node
    # needs no tf lookup and the targets we compute from ~state positions mean what we think they mean.
    frame_id = first.header.frame_id or "world"
    corner = (first.rows - 1) * first.cols  # bottom-left: row rows-1, column 0 (index row * cols + col)
    print(f"cloth_node: {first.rows} x {first.cols} particles, integrator {first.integrator} "
          f"x {first.substeps} substeps, frame '{frame_id}', mesh of {len(mesh.points) // 3} triangles")
    print(f"bottom-left corner (particle {corner}) at {fmt(first.positions[corner])} m")

    wind_pub = rospy.Publisher(node_ns + "/wind", Vector3Stamped, queue_size=1)
    grasp_pub = rospy.Publisher(node_ns + "/grasp", Grasp, queue_size=10)
    wait_for_connection(wind_pub)
    wait_for_connection(grasp_pub)

    grabbed = False
    try:
        # 2. Wind along +y: normal to the cloth, so it bellies out along +y.
        wind_pub.publish(make_wind(frame_id, wind_m_per_s))
        windy = states.wait_for(lambda s: s.sim_time >= first.sim_time + WIND_SETTLE_S,
                                WIND_SETTLE_S + STATE_TIMEOUT_S, f"state {WIND_SETTLE_S} s after the wind")
        print(f"wind {wind_m_per_s:+.1f} m/s along +y for {WIND_SETTLE_S:.1f} s: corner at "
              f"{fmt(windy.positions[corner])} m")

        # 3. Grab the corner where it is now, so the first pull is zero rather than a jerk.
        start = windy.positions[corner]
        grasp_pub.publish(make_grasp(frame_id, Grasp.GRAB, corner, start))
        grabbed = True

        # 4. Drag: a new GRAB with the same id moves the hand. The printed position is the latest
        #    state after each target; it lags the target by the spring's stretch.
        print(f"dragging round a {DRAG_RADIUS_M:.2f} m circle in {DRAG_STEPS} steps over {drag_s:.1f} s")
        print(" step   target (m)                  corner (m)                  error (m)")
        rate = rospy.Rate(DRAG_STEPS / drag_s)
        state = windy
        for step in range(1, DRAG_STEPS + 1):
            target = circle_target(start, step, DRAG_STEPS, DRAG_RADIUS_M)
            grasp_pub.publish(make_grasp(frame_id, Grasp.GRAB, corner, target))
            rate.sleep()
            state = states.newer_than(state)
            corner_m = state.positions[corner]
            print(f" {step:4d}   {fmt(target)}   {fmt(corner_m)}   {distance_m(corner_m, target):.3f}")
        settled = states.wait_for(lambda s: s.sim_time >= state.sim_time + HOLD_S,
                                  HOLD_S + STATE_TIMEOUT_S, "state after the hold")
        print(f"held {HOLD_S:.1f} s at the last target: "
              f"error {distance_m(settled.positions[corner], target):.3f} m")
    except BaseException:
        # A wait failed or the user pressed Ctrl-C: let go and stop the wind anyway, or the node keeps
        # holding the corner after we are gone. rospy sends from background threads, so give them a
        # moment before the process exits.
        release_and_calm(grasp_pub, wind_pub, frame_id, corner, grabbed)
        time.sleep(FLUSH_S)
        raise

    # 5. Let go and stop the wind.
    release_and_calm(grasp_pub, wind_pub, frame_id, corner, grabbed)

    last = states.wait_for(lambda s: s.sim_time >= settled.sim_time + AFTER_RELEASE_S,
                           AFTER_RELEASE_S + STATE_TIMEOUT_S, "state after the release")
    moved_m = distance_m(last.positions[corner], settled.positions[corner])
    print(f"released, wind off: {AFTER_RELEASE_S:.1f} s later the corner is at "
          f"{fmt(last.positions[corner])} m, {moved_m:.3f} m from where it was let go")
    print(f"summary: sim_time {last.sim_time:.2f} s, frame {last.frame} "
          f"({last.frame - first.frame} frames during this run), "
          f"kinetic energy {last.kinetic_energy:.4f} J, potential energy {last.potential_energy:.4f} J")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--node", default="/cloth_node",
                        help="namespace of cloth_node's topics (default: %(default)s)")
    parser.add_argument("--wind", type=float, default=3.0, metavar="M_PER_S",
                        help="wind speed along +y, m/s; 0 for none (default: %(default)s)")
    parser.add_argument("--seconds", type=float, default=2.0,
                        help="duration of the drag, s (default: %(default)s)")
    # rospy.myargv strips remappings (name:=value), which argparse would reject.
    args = parser.parse_args(rospy.myargv(argv=sys.argv)[1:])
    if args.seconds <= 0.0:
        parser.error("--seconds must be positive")
    if not abs(args.wind) <= 100.0:  # also catches NaN; the node drops wind above 100 m/s
        parser.error("--wind must be within +-100 m/s")

    # anonymous: several clients may run at once. disable_signals: Ctrl-C then raises
    # KeyboardInterrupt while rospy is still up, so run() can still publish the release.
    rospy.init_node("cloth_client", anonymous=True, disable_signals=True)
    try:
        run(args.node.rstrip("/"), args.wind, args.seconds)
        return 0
    except ClientError as error:
        print(f"cloth_client: {error}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, rospy.ROSInterruptException):
        print("cloth_client: interrupted (grasp released, wind stopped)", file=sys.stderr)
        return 130
    finally:
        rospy.signal_shutdown("cloth_client done")


if __name__ == "__main__":
    sys.exit(main())
