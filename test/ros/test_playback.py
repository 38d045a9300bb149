#!/usr/bin/python3
"""playback.launch plays a compact recording (ClothState only) and cloth_viewer turns it into the mesh.

Writes a short bag of a small cloth's states, starts `roslaunch cloth_sim playback.launch bag:=...
rviz:=false loop:=false` against the test's master, and waits for /cloth_node/mesh: a TRIANGLE_LIST of
6 (rows - 1)(cols - 1) points at the recorded positions. Run by test/ros/playback.test.
"""
import os
import subprocess
import tempfile
import time
import unittest

import rosbag
import rospy
import rostest
from cloth_sim.msg import ClothState
from geometry_msgs.msg import Point, Vector3
from visualization_msgs.msg import Marker

ROWS, COLS = 4, 5
FRAMES = 100          # 2 s at 50 Hz: long enough for the viewer to connect before the bag ends
FRAME_S = 0.02
DEADLINE_S = 30.0
SPACING_M = 0.1


def recorded_state(frame):
    """A flat ROWS x COLS cloth in the x-z plane sinking 1 mm per frame."""
    state = ClothState()
    state.header.frame_id = "world"
    state.header.stamp = rospy.Time.from_sec(1.0 + frame * FRAME_S)
    state.rows, state.cols = ROWS, COLS
    state.positions = [Point(c * SPACING_M, 0.0, 1.0 - r * SPACING_M - 0.001 * frame)
                       for r in range(ROWS) for c in range(COLS)]
    state.velocities = [Vector3(0.0, 0.0, -0.05)] * (ROWS * COLS)
    state.sim_time = frame * FRAME_S
    state.frame = frame
    state.integrator = "implicit_euler"
    state.substeps = 1
    return state


class Playback(unittest.TestCase):
    def test_a_compact_recording_plays_into_the_viewer_as_a_mesh(self):
        meshes = []
        rospy.Subscriber("/cloth_node/mesh", Marker, meshes.append, queue_size=10)
        with tempfile.TemporaryDirectory() as folder:
            bag_path = os.path.join(folder, "states.bag")
            with rosbag.Bag(bag_path, "w", compression="lz4") as bag:
                for frame in range(FRAMES):
                    state = recorded_state(frame)
                    bag.write("/cloth_node/state", state, state.header.stamp)
            launch = subprocess.Popen(["roslaunch", "cloth_sim", "playback.launch", "bag:=" + bag_path, "rviz:=false",
                                       "loop:=false"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
            try:
                deadline = time.monotonic() + DEADLINE_S
                while not meshes and time.monotonic() < deadline and launch.poll() is None:
                    time.sleep(0.05)
            finally:
                launch.terminate()
                output = launch.communicate(timeout=DEADLINE_S)[0].decode(errors="replace")
        self.assertTrue(meshes, "no mesh from playback.launch; roslaunch said:\n" + output[-2000:])
        mesh = meshes[0]
        self.assertEqual(mesh.type, Marker.TRIANGLE_LIST)
        self.assertEqual(mesh.header.frame_id, "world")
        self.assertEqual(len(mesh.points), 6 * (ROWS - 1) * (COLS - 1))
        self.assertEqual(len(mesh.colors), len(mesh.points))
        # Every point is one of the recorded particles (the first triangle starts at particle 0).
        xs = sorted({round(p.x, 6) for p in mesh.points})
        self.assertEqual(xs, [round(c * SPACING_M, 6) for c in range(COLS)])


if __name__ == "__main__":
    rospy.init_node("test_playback")
    rostest.rosrun("cloth_sim", "playback", Playback)
