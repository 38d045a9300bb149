#!/usr/bin/python3
"""~mesh without ~mesh_rate follows the running scene's frame rate (run by test/ros/mesh_rate.test).

cloth_slow starts at 10 frames a second (the frame_rate parameter) and no mesh_rate, then ~load_scene
loads the hanging scene at 50: its ~mesh must come with every ~state, as it did at 10. Before, the mesh
rate was fixed at start-up from the first scene (10 Hz), and the 50 Hz scene drew a mesh every fifth
frame. A count of messages over the same window, not a time.
"""
import threading
import time
import unittest

import rospy
import rostest
from cloth_sim.msg import ClothState
from cloth_sim.srv import LoadScene
from visualization_msgs.msg import Marker

NODE = "/cloth_slow"
DEADLINE_S = 30.0
WINDOW_FRAMES = 100     # ~state messages counted after the new scene runs
MESH_SHARE = 0.8        # at least this many meshes per state (0.2 when the mesh kept the first scene's rate)
FRAME_PERIOD_S = 0.02   # the hanging scene's 50 Hz
OLD_FRAMES = 3          # frames of the 10 Hz scene seen before the new one is loaded (its counter then goes back)


class MeshFollowsTheScene(unittest.TestCase):
    def test_the_mesh_comes_at_the_new_scenes_frame_rate(self):
        lock = threading.Lock()
        counts = {"state": 0, "mesh": 0}
        loaded = {"done": False, "restarted": False, "frame_before": 0}
        stamps = []

        def on_state(message):
            with lock:
                # The new scene counts its frames from 0: count from its first message on.
                if loaded["done"] and not loaded["restarted"]:
                    if message.frame >= loaded["frame_before"]:
                        return
                    loaded["restarted"] = True
                    counts["state"] = counts["mesh"] = 0
                    del stamps[:]
                counts["state"] += 1
                stamps.append(message.header.stamp.to_sec())
                loaded["frame_before"] = max(loaded["frame_before"], message.frame)

        def on_mesh(_):
            with lock:
                counts["mesh"] += 1

        rospy.Subscriber(NODE + "/state", ClothState, on_state, queue_size=100)
        rospy.Subscriber(NODE + "/mesh", Marker, on_mesh, queue_size=100)
        rospy.wait_for_service(NODE + "/load_scene", DEADLINE_S)
        deadline = time.monotonic() + DEADLINE_S
        while time.monotonic() < deadline:
            with lock:
                if counts["mesh"] > 0 and loaded["frame_before"] >= OLD_FRAMES:
                    break
            time.sleep(0.05)
        with lock:
            loaded["done"] = True  # from here a ~state whose frame went back is the new scene's
        answer = rospy.ServiceProxy(NODE + "/load_scene", LoadScene)(scene="hanging")
        self.assertTrue(answer.success, answer.message)
        while time.monotonic() < deadline + DEADLINE_S:
            with lock:
                if counts["state"] >= WINDOW_FRAMES:
                    break
            time.sleep(0.05)
        with lock:
            state, mesh = counts["state"], counts["mesh"]
            spacing_s = (stamps[-1] - stamps[0]) / max(1, len(stamps) - 1)
        self.assertGreaterEqual(state, WINDOW_FRAMES)
        self.assertAlmostEqual(spacing_s, FRAME_PERIOD_S, delta=0.5 * FRAME_PERIOD_S,
                               msg="~state is not at the new scene's 50 Hz")
        self.assertGreaterEqual(mesh, MESH_SHARE * state, "%d meshes for %d states" % (mesh, state))


if __name__ == "__main__":
    rospy.init_node("test_mesh_rate_follows")
    rostest.rosrun("cloth_sim", "mesh_rate_follows", MeshFollowsTheScene)
