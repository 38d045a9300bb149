#!/usr/bin/python3
"""Robot links as colliders (issue 14 §4), through the node's real tf, topics and diagnostics.

test/ros/frame_colliders.test runs cloth_node on the hanging scene (20 x 20, 1 m, in the x-z plane at
y = 0) with a capsule (radius 0.04 m, core 0.5 m) on the tf frame `sweeper` and the URDF
test_robot.urdf (a sphere, a cylinder, a box and a mesh link). This test publishes those frames in tf:
- it sweeps the capsule, upright, through the cloth along +y at 5 m/s. For every ~state, the ~colliders
  markers of the same stamp show where the capsule stood in that frame, and no particle may be inside it
  (deeper than the contact band);
- the URDF gives three colliders (the mesh link is skipped), four in all with the parameter's;
- the node never re-broadcasts the colliders' frames on /tf.
"""
import math
import os
import signal
import subprocess
import tempfile
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from cloth_sim.msg import ClothState
from cloth_sim.srv import LoadState, SaveState
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

DEADLINE_S = 30.0
RADIUS_M = 0.04
CORE_M = 0.5
DEPTH_M = 0.002  # the scene's contact band
SPEED_M_PER_S = 5.0
SWEEP_END_Y_M = 0.8  # the sweeper goes from -0.8 m to 0.8 m along y and stays there
REST_FRAMES = 25  # half a second of states
SETTLED_MARKERS = 75  # a second and a half of ticks at 50 Hz
REST_MOTION_M = 1e-3  # the most any particle may move over REST_FRAMES for the cloth to count as at rest
PUBLISH_HZ = 100.0
LINK_FRAMES = ["sweeper", "ball_link", "rod_link", "plate_link", "mesh_link"]


def rotate(q, v):
    """Rotates v by the quaternion q = (x, y, z, w)."""
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


class Frames:
    """Publishes the link frames on /tf at PUBLISH_HZ, stamped now; the sweeper on a path in time."""

    def __init__(self):
        self.lock = threading.Lock()
        self.sweep_start = None
        self.publisher = rospy.Publisher("/tf", TFMessage, queue_size=100)
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def start_sweep(self):
        with self.lock:
            self.sweep_start = rospy.Time.now()

    def sweeper_y(self, now):
        with self.lock:
            start = self.sweep_start
        if start is None:
            return -SWEEP_END_Y_M
        return min(-SWEEP_END_Y_M + SPEED_M_PER_S * (now - start).to_sec(), SWEEP_END_Y_M)

    def run(self):
        rate = rospy.Rate(PUBLISH_HZ)
        while not rospy.is_shutdown():
            now = rospy.Time.now()
            transforms = []
            for k, name in enumerate(LINK_FRAMES):
                t = TransformStamped()
                t.header.stamp = now
                t.header.frame_id = "world"
                t.child_frame_id = name
                if name == "sweeper":
                    t.transform.translation.y = self.sweeper_y(now)
                    t.transform.translation.z = 1.0
                else:  # the URDF's links stand far from the cloth
                    t.transform.translation.x = 5.0 + k
                t.transform.rotation.w = 1.0
                transforms.append(t)
            self.publisher.publish(TFMessage(transforms=transforms))
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                return


class FrameColliders(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.states = {}
        cls.markers = {}
        cls.rebroadcast = []
        cls.diagnostics = None
        cls.frames = Frames()
        rospy.Subscriber("/cloth_node/state", ClothState, cls.on_state, queue_size=50)
        rospy.Subscriber("/cloth_node/colliders", MarkerArray, cls.on_markers, queue_size=50)
        rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=200)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.on_diagnostics, queue_size=10)

    @classmethod
    def on_state(cls, state):
        with cls.lock:
            cls.states[state.header.stamp.to_nsec()] = state

    @classmethod
    def on_markers(cls, array):
        capsule = [m for m in array.markers if m.ns == "frame_colliders" and m.type == Marker.CYLINDER]
        if capsule:
            with cls.lock:
                cls.markers[capsule[0].header.stamp.to_nsec()] = capsule[0]

    @classmethod
    def on_tf(cls, message):
        if message._connection_header.get("callerid") == "/cloth_node":
            names = [t.child_frame_id for t in message.transforms if t.child_frame_id in LINK_FRAMES]
            if names:
                with cls.lock:
                    cls.rebroadcast.extend(names)

    @classmethod
    def on_diagnostics(cls, array):
        for status in array.status:
            if status.name.endswith("frame colliders"):
                with cls.lock:
                    cls.diagnostics = status

    def wait_for(self, condition, deadline_s=DEADLINE_S):
        deadline = time.monotonic() + deadline_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if condition():
                    return True
            time.sleep(0.05)
        return False

    def test_a_capsule_sweeping_at_5_m_per_s_leaves_no_particle_inside_in_any_frame(self):
        # The capsule is drawn once its frame is known. The sweep starts once the node has drawn it for
        # SETTLED_MARKERS ticks (past its start-up, when a late tick carries several frames and draws one
        # capsule for them, too few frames near the cloth to prove anything) and the cloth is at rest (its
        # particles moved under REST_MOTION_M over the last REST_FRAMES states), not after a fixed sleep.
        self.assertTrue(self.wait_for(lambda: len(self.markers) > SETTLED_MARKERS), "no capsule on ~colliders")

        def at_rest():
            stamps = sorted(self.states)
            if len(stamps) <= REST_FRAMES:
                return False
            now, before = self.states[stamps[-1]], self.states[stamps[-1 - REST_FRAMES]]
            return max(abs(a.x - b.x) + abs(a.y - b.y) + abs(a.z - b.z)
                       for a, b in zip(now.positions, before.positions)) < REST_MOTION_M
        self.assertTrue(self.wait_for(at_rest), "the cloth never came to rest before the sweep")
        self.frames.start_sweep()
        sweep_start_ns = rospy.Time.now().to_nsec()

        def swept_and_drawn():  # a state and a capsule at the sweep's end (y = 0.8), frames after it began
            return any(stamp > sweep_start_ns and marker.pose.position.y >= SWEEP_END_Y_M - 1e-9
                       and stamp in self.states for stamp, marker in self.markers.items())
        self.assertTrue(self.wait_for(swept_and_drawn), "the capsule never reached the end of its sweep")
        with self.lock:
            pairs = [(self.states[s], self.markers[s]) for s in sorted(self.markers) if s in self.states]
        crossing = 0
        worst_m = 0.0
        pushed_m = 0.0
        for state, capsule in pairs:
            centre = np.array([capsule.pose.position.x, capsule.pose.position.y, capsule.pose.position.z])
            q = (capsule.pose.orientation.x, capsule.pose.orientation.y, capsule.pose.orientation.z,
                 capsule.pose.orientation.w)
            axis = rotate(q, np.array([0.0, 0.0, 1.0]))
            points = np.array([[p.x, p.y, p.z] for p in state.positions])
            along = np.clip((points - centre) @ axis, -CORE_M / 2, CORE_M / 2)
            distance = np.linalg.norm(points - (centre + np.outer(along, axis)), axis=1) - RADIUS_M
            worst_m = max(worst_m, -distance.min())
            if abs(centre[1]) < 0.2:
                crossing += 1
            pushed_m = max(pushed_m, points[:, 1].max())
        self.assertGreaterEqual(crossing, 3, "too few frames with the capsule at the cloth to prove anything")
        self.assertLessEqual(worst_m, DEPTH_M + 1e-6, "a particle ended a frame %.4f m inside the capsule" % worst_m)
        self.assertGreater(pushed_m, 0.01, "the capsule never touched the cloth")

    def test_the_urdf_gives_its_sphere_cylinder_and_box_and_skips_the_mesh(self):
        def counted():
            if self.diagnostics is None:
                return False
            values = {v.key: v.value for v in self.diagnostics.values}
            return values.get("frame colliders") == "4" and values.get("frame colliders posed") == "4"
        self.assertTrue(self.wait_for(counted), "diagnostics never showed 4 frame colliders, all posed: %s" %
                        (self.diagnostics,))

    def test_the_node_never_rebroadcasts_the_links_frames(self):
        self.assertTrue(self.wait_for(lambda: len(self.states) > 50))
        with self.lock:
            self.assertEqual(self.rebroadcast, [])

    def test_z_a_state_saved_without_the_urdf_gets_its_colliders_when_loaded(self):
        # Last (its load replaces the capsule of ~frame_colliders). An audit's: a state file saved by a node
        # without this URDF replaced the node's URDF colliders with its own none, and the robot's links passed
        # through the cloth until the node restarted. A second node of the same scene, without a URDF, saves.
        plain = subprocess.Popen(["rosrun", "cloth_sim", "cloth_node", "__name:=plain_node", "_scene:=hanging"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            rospy.wait_for_service("/plain_node/save_state", timeout=DEADLINE_S)
            path = os.path.join(tempfile.mkdtemp(prefix="test_frame_colliders_"), "plain.state")
            saved = rospy.ServiceProxy("/plain_node/save_state", SaveState)(path)
            self.assertTrue(saved.success, saved.message)
        finally:
            plain.send_signal(signal.SIGINT)
            plain.wait(timeout=DEADLINE_S)
        loaded = rospy.ServiceProxy("/cloth_node/load_state", LoadState)(path)
        self.assertTrue(loaded.success, loaded.message)
        self.assertIn("added the URDF's 3 colliders it did not hold", loaded.message)
        # The file's own colliders (none) and the URDF's three, posed from their frames.
        with self.lock:
            type(self).diagnostics = None  # on_diagnostics sets the class's

        def urdf_only():
            if self.diagnostics is None:
                return False
            values = {v.key: v.value for v in self.diagnostics.values}
            return values.get("frame colliders") == "3" and values.get("frame colliders posed") == "3"
        self.assertTrue(self.wait_for(urdf_only), "diagnostics never showed the URDF's 3 frame colliders, posed: %s"
                        % (self.diagnostics,))


if __name__ == "__main__":
    rospy.init_node("test_frame_colliders")
    rostest.rosrun("cloth_sim", "frame_colliders", FrameColliders)
