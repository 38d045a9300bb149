#!/usr/bin/python3
"""Grippers on tf frames (issue 14 §2, §3), through the node's real services, topics and tf.

test/ros/grippers.test runs cloth_node on a 10 x 10, 0.5 kg cloth with no pins (scenes/held.yaml). This
test publishes gripper frames in tf itself and checks, in order:
- every refusal answers success=false naming the problem; ~reset, ~load_state and ~load_scene name the
  grippers they let go;
- statics: the cloth hanging still from one gripper pulls it with m g (1 %) and the torque of its centre
  of mass about the frame's origin; a turned frame reports the same vectors turned into it;
- a frame moved and turned carries its particles rigidly (1 mm), and they keep their mutual distances
  in every state on the way;
- a frame that stops being published: the cloth stays finite, the node up, the diagnostics WARN naming it;
  when it reappears 1.5 m away the cloth follows;
- ~detach lets the cloth fall.
"""
import math
import os
import re
import tempfile
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from cloth_sim.msg import ClothState
from cloth_sim.srv import Attach, AttachRequest, Detach, LoadScene, LoadState, SaveState
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped, WrenchStamped
from std_srvs.srv import SetBool, Trigger
from tf2_msgs.msg import TFMessage

DEADLINE_S = 30.0
ROWS, COLS = 10, 10
MASS_KG = 0.5
G = 9.81
WORLD = "world"
TOP_ROW = list(range(COLS))
PUBLISH_HZ = 50.0
SPACING_M = 1.0 / (COLS - 1)
SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "scenes", "held.yaml")  # grippers.test's


def rest_position(particle):
    """Where particle sits in the scene's rest grid (origin (-0.5, 0, 1.5), u = +x, v = -z)."""
    row, col = divmod(particle, COLS)
    return np.array([-0.5 + col * SPACING_M, 0.0, 1.5 - row * SPACING_M])


def quaternion_about(axis, angle):
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])  # w, x, y, z


def rotation_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class Frames:
    """Publishes gripper frames on /tf at PUBLISH_HZ, stamped now; a frame can be moved or stopped."""

    def __init__(self):
        self.lock = threading.Lock()
        self.poses = {}  # name -> (position, quaternion wxyz)
        self.publisher = rospy.Publisher("/tf", TFMessage, queue_size=100)
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def set(self, name, position, quaternion=(1.0, 0.0, 0.0, 0.0)):
        with self.lock:
            self.poses[name] = (np.asarray(position, dtype=float), np.asarray(quaternion, dtype=float))

    def stop(self, name):
        with self.lock:
            self.poses.pop(name, None)

    def run(self):
        rate = rospy.Rate(PUBLISH_HZ)
        while not rospy.is_shutdown():
            with self.lock:
                poses = dict(self.poses)
            stamp = rospy.Time.now()
            transforms = []
            for name, (p, q) in poses.items():
                t = TransformStamped()
                t.header.stamp = stamp
                t.header.frame_id = WORLD
                t.child_frame_id = name
                t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = p
                t.transform.rotation.w, t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z = q
                transforms.append(t)
            if transforms:
                self.publisher.publish(TFMessage(transforms=transforms))
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                return


class Latest:
    """The newest message of a topic, and a wait for a condition on it."""

    def __init__(self, topic, kind, on_message=None):
        self.lock = threading.Lock()
        self.message = None
        self.on_message = on_message
        self.subscriber = rospy.Subscriber(topic, kind, self.store, queue_size=20)

    def store(self, message):
        with self.lock:
            self.message = message
        if self.on_message is not None:
            self.on_message(message)

    def wait_for(self, condition, deadline_s=DEADLINE_S):
        deadline = time.monotonic() + deadline_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                message = self.message
            if message is not None and condition(message):
                return message
            time.sleep(0.05)
        return None


def positions(state):
    return np.array([[p.x, p.y, p.z] for p in state.positions])


def vector(v):
    return np.array([v.x, v.y, v.z])


class Grippers(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.frames = Frames()
        rospy.wait_for_service("/cloth_node/attach", DEADLINE_S)
        rospy.wait_for_service("/cloth_node/detach", DEADLINE_S)
        rospy.wait_for_service("/cloth_node/pause", DEADLINE_S)
        cls.attach = rospy.ServiceProxy("/cloth_node/attach", Attach)
        cls.detach = rospy.ServiceProxy("/cloth_node/detach", Detach)
        cls.pause = rospy.ServiceProxy("/cloth_node/pause", SetBool)
        cls.reset = rospy.ServiceProxy("/cloth_node/reset", Trigger)
        cls.save_state = rospy.ServiceProxy("/cloth_node/save_state", SaveState)
        cls.load_state = rospy.ServiceProxy("/cloth_node/load_state", LoadState)
        cls.load_scene = rospy.ServiceProxy("/cloth_node/load_scene", LoadScene)
        cls.state = Latest("/cloth_node/state", ClothState)
        cls.diagnostics = Latest("/diagnostics", DiagnosticArray)
        cls.first = cls.state.wait_for(lambda s: len(s.positions) == ROWS * COLS)
        assert cls.first is not None, "no ~state"

    def from_rest(self):
        """Paused at the scene's start (nothing holds the cloth: it must not run until a gripper does)."""
        self.assertTrue(self.pause(True).success)
        self.assertTrue(self.reset().success)

    def run_on(self):
        self.assertTrue(self.pause(False).success)

    def request(self, gripper_id, frame, radius=0.0, particles=(), max_force=0.0):
        request = AttachRequest()
        request.id = gripper_id
        request.frame = frame
        request.radius = radius
        request.particles = list(particles)
        request.max_force = max_force
        return self.attach(request)

    def refused(self, response, expected):
        self.assertFalse(response.success, "accepted; expected a refusal naming '%s'" % expected)
        self.assertIn(expected, response.message)

    def attach_stale(self, gripper_id, frame, position, age_s):
        """Publishes `frame` once at `position`, stamped age_s ago, and attaches it (retrying until tf knows it)."""
        publisher = rospy.Publisher("/tf", TFMessage, queue_size=10)
        deadline = time.monotonic() + DEADLINE_S
        while True:
            t = TransformStamped()
            t.header.stamp = rospy.Time.now() - rospy.Duration(age_s)
            t.header.frame_id = WORLD
            t.child_frame_id = frame
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = position
            t.transform.rotation.w = 1.0
            publisher.publish(TFMessage(transforms=[t]))
            response = self.request(gripper_id, frame, particles=[5])
            if "unknown frame" not in response.message or time.monotonic() > deadline:
                return response
            time.sleep(0.1)

    def attach_when_known(self, *args, **kwargs):
        """Attaches, retrying while the node's tf does not know the frame yet (it was just published)."""
        deadline = time.monotonic() + DEADLINE_S
        while True:
            response = self.request(*args, **kwargs)
            if response.success or "unknown frame" not in response.message or time.monotonic() > deadline:
                return response
            time.sleep(0.1)

    def test_1_every_refusal_names_its_problem(self):
        self.from_rest()
        top = rest_position(COLS // 2)
        self.frames.set("refusals", top)
        self.frames.set("far_away", top + np.array([0.0, 0.0, 5.0]))
        self.refused(self.request(1, "no_such_frame", particles=[0]), "unknown frame 'no_such_frame'")
        self.refused(self.attach_when_known(1, "far_away", radius=0.1), "catches no particle")
        self.refused(self.attach_when_known(1, "refusals", particles=[100]), "particle 100 is outside [0, 99]")
        self.refused(self.request(1, "refusals", particles=[-3]), "particle -3 is outside")
        self.refused(self.request(1, "refusals", radius=-0.1), "radius")
        self.refused(self.request(1, "refusals", radius=float("nan")), "radius")
        self.refused(self.request(1, "refusals", particles=[0], max_force=float("inf")), "max_force")
        self.refused(self.request(1, "refusals", particles=[0], max_force=-2.0), "max_force")
        self.refused(self.request(1, "", particles=[0]), "frame")
        # A frame whose newest transform is older than the node follows (it stopped being published) is refused
        # naming its age; it was taken, and the next frame called the gripper lost.
        stale = self.attach_stale(1, "stale", top, age_s=3.0)
        self.refused(stale, "s old at the next frame's end (a gripper follows a frame at most 0.5 s stale)")
        age = re.search(r"the newest transform of frame 'stale' is ([0-9.]+) s old", stale.message)
        self.assertIsNotNone(age, stale.message)
        self.assertGreaterEqual(float(age.group(1)), 3.0, stale.message)
        held = self.request(1, "refusals", particles=[5])
        self.assertTrue(held.success, held.message)
        self.assertEqual(list(held.particles), [5])
        self.refused(self.request(1, "refusals", particles=[6]), "already attached")
        self.refused(self.request(2, "refusals", particles=[5]), "already held by gripper 1 ('refusals')")
        self.assertTrue(self.detach(1).success)
        self.refused(self.detach(1), "no gripper 1")
        # A reset detaches every gripper and says which: their clients must attach again.
        attached = self.request(3, "refusals", particles=[5])
        self.assertTrue(attached.success, attached.message)
        reset = self.reset()
        self.assertTrue(reset.success)
        self.assertTrue(reset.message.endswith("back at frame 0; detached gripper ids 3"), reset.message)
        self.refused(self.detach(3), "no gripper 3")
        # So do ~load_state (the file's grippers replace the running ones) and ~load_scene.
        path = os.path.join(tempfile.mkdtemp(prefix="test_grippers_"), "nothing_held.state")
        saved = self.save_state(path)
        self.assertTrue(saved.success, saved.message)
        attached = self.request(4, "refusals", particles=[5])
        self.assertTrue(attached.success, attached.message)
        loaded = self.load_state(path)
        self.assertTrue(loaded.success, loaded.message)
        self.assertTrue(loaded.message.endswith(path + "; detached gripper ids 4"), loaded.message)
        self.refused(self.detach(4), "no gripper 4")
        attached = self.request(6, "refusals", particles=[5])
        self.assertTrue(attached.success, attached.message)
        loaded = self.load_scene(SCENE)
        self.assertTrue(loaded.success, loaded.message)
        self.assertTrue(loaded.message.endswith("(10x10); detached gripper ids 6"), loaded.message)
        self.refused(self.detach(6), "no gripper 6")
        self.frames.stop("refusals")
        self.frames.stop("far_away")

    def hang_and_measure(self, gripper_id, frame, origin, quaternion):
        """Holds the top row in `frame` at `origin` turned by `quaternion`, waits for rest; the wrench and
        the centre of mass then."""
        self.from_rest()
        self.frames.set(frame, origin, quaternion)
        held = self.attach_when_known(gripper_id, frame, particles=TOP_ROW)
        wrenches = Latest("/cloth_node/gripper_%d/wrench" % gripper_id, WrenchStamped)
        self.assertTrue(held.success, held.message)
        self.run_on()
        weight = MASS_KG * G
        still = self.state.wait_for(
            lambda s: s.frame > 150 and max(np.linalg.norm(vector(v)) for v in s.velocities) < 1e-3, deadline_s=60.0)
        self.assertIsNotNone(still, "the cloth never came to rest")
        wrench = wrenches.wait_for(lambda w: w.header.stamp >= still.header.stamp)
        self.assertIsNotNone(wrench, "no ~gripper_%d/wrench" % gripper_id)
        self.assertEqual(wrench.header.frame_id, frame)
        state = self.state.message
        centre = positions(state).mean(axis=0)  # equal masses
        return vector(wrench.wrench.force), vector(wrench.wrench.torque), centre, weight

    def test_2_statics_one_gripper_pulls_with_the_weight_and_its_torque_and_turns_with_its_frame(self):
        origin = rest_position(0) + np.array([0.3, 0.1, 0.05])  # off the line of the weight: a torque to measure
        identity = np.array([1.0, 0.0, 0.0, 0.0])
        force, torque, centre, weight = self.hang_and_measure(3, "hand_static", origin, identity)
        world_force = np.array([0.0, 0.0, -weight])
        self.assertLess(np.linalg.norm(force - world_force), 0.01 * weight, "force %s" % force)
        expected_torque = np.cross(centre - origin, world_force)
        self.assertGreater(np.linalg.norm(expected_torque), 0.05)
        self.assertLess(np.linalg.norm(torque - expected_torque), 0.01 * np.linalg.norm(expected_torque) + 1e-3,
                        "torque %s, expected %s" % (torque, expected_torque))
        self.assertTrue(self.detach(3).success)
        self.frames.stop("hand_static")

        # The same hold in a frame turned 90 degrees about z and 30 about x: the vectors turn into it.
        turn = quaternion_about([0.0, 0.0, 1.0], math.pi / 2)
        tilt = quaternion_about([1.0, 0.0, 0.0], math.pi / 6)
        w1, x1, y1, z1 = turn
        w2, x2, y2, z2 = tilt
        q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                      w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
        force, torque, centre, weight = self.hang_and_measure(4, "hand_turned", origin, q)
        to_frame = rotation_matrix(q).T
        expected_force = to_frame @ world_force
        expected_torque = to_frame @ np.cross(centre - origin, world_force)
        self.assertLess(np.linalg.norm(force - expected_force), 0.01 * weight, "force %s vs %s" % (force, expected_force))
        self.assertLess(np.linalg.norm(torque - expected_torque), 0.01 * np.linalg.norm(expected_torque) + 1e-3)
        self.assertTrue(self.detach(4).success)
        self.frames.stop("hand_turned")

    def test_3_a_moving_turning_frame_carries_its_particles_rigidly_and_detach_drops_them(self):
        self.from_rest()
        start = rest_position(COLS // 2) + np.array([0.0, 0.05, 0.0])
        q0 = np.array([1.0, 0.0, 0.0, 0.0])
        self.frames.set("hand_moving", start, q0)
        held = self.attach_when_known(5, "hand_moving", radius=0.25)
        self.assertTrue(held.success, held.message)
        particles = list(held.particles)
        self.assertGreaterEqual(len(particles), 3)
        attached = np.array([rest_position(i) for i in particles])
        self.run_on()
        offsets = (rotation_matrix(q0).T @ (attached - start).T).T
        pair_distances = np.linalg.norm(attached[:, None, :] - attached[None, :, :], axis=2)
        worst_pairs = [0.0]

        def rigid(message):
            p = positions(message)[particles]
            worst_pairs[0] = max(worst_pairs[0], np.abs(np.linalg.norm(p[:, None, :] - p[None, :, :], axis=2) -
                                                         pair_distances).max())

        watcher = Latest("/cloth_node/state", ClothState, on_message=rigid)
        # Over 2 s: 0.4 m up and sideways while turning 1 rad about a tilted axis, then held there.
        end = start + np.array([0.2, 0.1, 0.35])
        axis = [0.3, 1.0, 0.5]
        steps = int(2.0 * PUBLISH_HZ)
        for k in range(1, steps + 1):
            s = k / steps
            self.frames.set("hand_moving", start + s * (end - start), quaternion_about(axis, 1.0 * s))
            time.sleep(1.0 / PUBLISH_HZ)
        q_end = quaternion_about(axis, 1.0)
        expected = end + (rotation_matrix(q_end) @ offsets.T).T
        there = self.state.wait_for(lambda m: np.abs(positions(m)[particles] - expected).max() < 1e-3)
        self.assertIsNotNone(there, "held particles did not reach the frame's end pose within 1 mm: off by %.4f m" %
                             np.abs(positions(self.state.message)[particles] - expected).max())
        watcher.subscriber.unregister()
        self.assertLess(worst_pairs[0], 1e-6, "held particles moved relative to each other")

        # The frame stops being published: finite cloth, node up, a WARN naming it.
        self.frames.stop("hand_moving")

        def warns(array):
            return any(s.level == DiagnosticStatus.WARN and "hand_moving" in s.message and "lost" in s.message
                       for s in array.status)

        self.assertIsNotNone(self.diagnostics.wait_for(warns), "no diagnostics WARN naming the lost frame")
        lost = self.state.wait_for(lambda m: m.header.stamp > there.header.stamp)
        self.assertTrue(np.isfinite(positions(lost)).all())
        self.assertLess(np.abs(positions(lost)[particles] - expected).max(), 1e-3, "held particles moved while lost")

        # It reappears 1.5 m away: the cloth follows, finite all the way.
        far = end + np.array([1.5, 0.0, 0.0])
        self.frames.set("hand_moving", far, q_end)
        far_expected = far + (rotation_matrix(q_end) @ offsets.T).T
        followed = self.state.wait_for(lambda m: not np.isfinite(positions(m)).all() or
                                       np.abs(positions(m)[particles] - far_expected).max() < 1e-3)
        self.assertIsNotNone(followed, "the cloth did not follow the frame back")
        self.assertTrue(np.isfinite(positions(followed)).all())

        # Let go: the cloth falls.
        self.assertTrue(self.detach(5).success)
        self.frames.stop("hand_moving")
        fell = self.state.wait_for(lambda m: positions(m)[particles][:, 2].max() < far_expected[:, 2].min() - 0.3)
        self.assertIsNotNone(fell, "the cloth did not fall after ~detach")


if __name__ == "__main__":
    rospy.init_node("test_grippers")
    rostest.rosrun("cloth_sim", "grippers", Grippers)
