#!/usr/bin/python3
"""playback.launch plays a compact recording (ClothState only): cloth_viewer turns it into the mesh, and the
fixed frame is in tf although the bag holds no tf at all.

Writes a short bag of a small cloth's states, starts `roslaunch cloth_sim playback.launch bag:=...
rviz:=false loop:=false` against the test's master, and waits
  - with viewer:=true, for /cloth_node/mesh: a TRIANGLE_LIST of 6 (rows - 1)(cols - 1) points at the
    recorded positions;
  - with viewer:=true at 25 Hz from a recording whose even states are malformed, for meshes of the odd
    ones: a state the viewer drops does not use up a mesh's turn;
  - with viewer:=true from states whose `active` leaves a particle out (an outline), for a mesh without it;
  - with the defaults, for /tf_static to carry `world` (rviz's fixed frame in config/cloth.rviz) as a
    child of `map`: without it rviz's Global Status stays at Warn ("Fixed Frame: No tf data").
Run by test/ros/playback.test.
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
from tf2_msgs.msg import TFMessage
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


def malformed_on_even_frames(frame):
    """recorded_state, with one particle short of rows x cols on even frames: the viewer must drop those."""
    state = recorded_state(frame)
    if frame % 2 == 0:
        state.positions = state.positions[:-1]
    return state


def outlined_state(frame):
    """recorded_state of a cloth whose outline left particle 0 out: frozen far from the rest, not cloth."""
    state = recorded_state(frame)
    state.positions[0] = Point(5.0, 5.0, 5.0)
    state.active = [0] + [1] * (ROWS * COLS - 1)
    return state


def write_bag(path, make_state=recorded_state):
    with rosbag.Bag(path, "w", compression="lz4") as bag:
        for frame in range(FRAMES):
            state = make_state(frame)
            bag.write("/cloth_node/state", state, state.header.stamp)


def play_until(arguments, done, make_state=recorded_state):
    """Runs playback.launch with `arguments` on a fresh bag of make_state's states until done() or the
    deadline; roslaunch's output."""
    with tempfile.TemporaryDirectory() as folder:
        bag_path = os.path.join(folder, "states.bag")
        write_bag(bag_path, make_state)
        launch = subprocess.Popen(["roslaunch", "cloth_sim", "playback.launch", "bag:=" + bag_path, "rviz:=false",
                                   "loop:=false"] + arguments, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        try:
            deadline = time.monotonic() + DEADLINE_S
            while not done() and time.monotonic() < deadline and launch.poll() is None:
                time.sleep(0.05)
        finally:
            launch.terminate()
            output = launch.communicate(timeout=DEADLINE_S)[0]
    return output.decode(errors="replace")


class Playback(unittest.TestCase):
    def test_a_compact_recording_plays_into_the_viewer_as_a_mesh(self):
        meshes = []
        subscriber = rospy.Subscriber("/cloth_node/mesh", Marker, meshes.append, queue_size=10)
        output = play_until(["viewer:=true"], lambda: meshes)
        subscriber.unregister()
        self.assertTrue(meshes, "no mesh from playback.launch viewer:=true; roslaunch said:\n" + output[-2000:])
        mesh = meshes[0]
        self.assertEqual(mesh.type, Marker.TRIANGLE_LIST)
        self.assertEqual(mesh.header.frame_id, "world")
        self.assertEqual(len(mesh.points), 6 * (ROWS - 1) * (COLS - 1))
        self.assertEqual(len(mesh.colors), len(mesh.points))
        # Every point is one of the recorded particles (the first triangle starts at particle 0).
        xs = sorted({round(p.x, 6) for p in mesh.points})
        self.assertEqual(xs, [round(c * SPACING_M, 6) for c in range(COLS)])

    def test_a_state_the_viewer_drops_does_not_take_a_mesh_s_turn(self):
        # At 25 Hz from 50 Hz states the schedule wants every other state, and every one it would pick (the
        # even frames, from the first) is malformed here. The viewer used to count a dropped state as drawn,
        # so the well-formed state after it was a period early and no mesh was ever drawn.
        meshes = []
        rospy.set_param("/cloth_viewer/mesh_rate", 25.0)
        try:
            subscriber = rospy.Subscriber("/cloth_node/mesh", Marker, meshes.append, queue_size=100)
            output = play_until(["viewer:=true"], lambda: len(meshes) >= 3, malformed_on_even_frames)
            subscriber.unregister()
        finally:
            rospy.delete_param("/cloth_viewer/mesh_rate")
        self.assertGreaterEqual(len(meshes), 3, "the viewer drew no mesh from the well-formed (odd) states; "
                                "roslaunch said:\n" + output[-2000:])
        for mesh in meshes:
            frame = round((mesh.header.stamp.to_sec() - 1.0) / FRAME_S)
            self.assertEqual(frame % 2, 1, "a mesh from a malformed state")
            self.assertEqual(len(mesh.points), 6 * (ROWS - 1) * (COLS - 1))

    def test_particles_outside_an_outline_are_left_out_of_the_mesh(self):
        # The quad at particle 0 loses both its triangles (the node's own ~mesh leaves them out the same way).
        meshes = []
        subscriber = rospy.Subscriber("/cloth_node/mesh", Marker, meshes.append, queue_size=10)
        output = play_until(["viewer:=true"], lambda: meshes, outlined_state)
        subscriber.unregister()
        self.assertTrue(meshes, "no mesh from playback.launch viewer:=true; roslaunch said:\n" + output[-2000:])
        self.assertEqual(len(meshes[0].points), 6 * (ROWS - 1) * (COLS - 1) - 6)
        self.assertFalse([p for p in meshes[0].points if p.x == 5.0], "the removed particle was drawn")

    def test_the_viewer_refuses_a_parameter_of_the_wrong_type_by_name(self):
        # ros::param's defaults used to take over in silence: a mesh_rate of 'abc' drew at 50 Hz, a
        # publish_mesh of 0 still drew, an empty state_topic subscribed to '/'; a topic name ROS refuses
        # (9bad, a%b, ~state) aborted the viewer (exit 134).
        # A negative mesh_rate beside publish_mesh:=false was taken (checked only when a mesh was published).
        # A viewer of its own name for each: a private parameter set from the command line stays on the master.
        for k, (arguments, named) in enumerate(((["_mesh_rate:=abc"], "~mesh_rate"),
                                                (["_publish_mesh:=0"], "~publish_mesh"),
                                                (["_state_topic:="], "~state_topic"), (["_frame_id:=5"], "~frame_id"),
                                                (["_state_topic:=9bad"], "~state_topic"),
                                                (["_state_topic:=~state"], "~state_topic"),
                                                (["_mesh_topic:=a%b"], "~mesh_topic"),
                                                (["_mesh_rate:=-5", "_publish_mesh:=false"], "~mesh_rate"))):
            viewer = subprocess.run(["rosrun", "cloth_sim", "cloth_viewer", "__name:=bad_viewer_%d" % k] + arguments,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=DEADLINE_S)
            output = viewer.stdout.decode(errors="replace")
            self.assertEqual(viewer.returncode, 1, " ".join(arguments) + " was taken: " + output[-1000:])
            self.assertIn(named, output, " ".join(arguments))

    def test_a_recording_without_tf_still_has_the_fixed_frame(self):
        # The bag written here holds no /tf and no /tf_static: the frame can only come from the launch.
        frames = {}
        states = []

        def on_tf_static(message):
            for transform in message.transforms:
                frames[transform.child_frame_id] = transform
        tf_subscriber = rospy.Subscriber("/tf_static", TFMessage, on_tf_static, queue_size=10)
        state_subscriber = rospy.Subscriber("/cloth_node/state", ClothState, states.append, queue_size=10)
        output = play_until([], lambda: "world" in frames and states)
        tf_subscriber.unregister()
        state_subscriber.unregister()
        self.assertIn("world", frames, "no static tf for 'world' from playback.launch; roslaunch said:\n" + output[-2000:])
        world = frames["world"]
        self.assertEqual(world.header.frame_id, "map")
        self.assertEqual(world.transform.rotation.w, 1.0)
        self.assertEqual((world.transform.translation.x, world.transform.translation.y,
                          world.transform.translation.z), (0.0, 0.0, 0.0))
        # The recorded states carry the same frame, so rviz can place them in it.
        self.assertTrue(states, "the recording was not played")
        self.assertEqual(states[0].header.frame_id, "world")


if __name__ == "__main__":
    rospy.init_node("test_playback")
    rostest.rosrun("cloth_sim", "playback", Playback)
