#!/usr/bin/python3
"""A short `make load` in the suite: ~wind at 10 kHz and ~grasp at 1 kHz for 5 s on a 20x20 cloth.

The node must keep advancing and publishing (wide margins: the machine is shared), keep its memory
bounded (its subscriber queues drop what it cannot read), and still answer a service call afterwards.
scripts/load.py does the flooding and measuring. Run by test/ros/load.test.
"""
import os
import sys
import unittest

import rospy
import rostest
from std_srvs.srv import SetBool

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import load  # noqa: E402  (scripts/ is not a Python package)

NODE = "/cloth_node"
SECONDS = 5.0
WIND_HZ = 10000.0
GRASP_HZ = 1000.0
FRAME_RATE_HZ = 50.0
# Wide margins: a tenth of the target rates still floods a 50 Hz node; a quarter of its rates still shows
# it was not starved; a leak would grow with the 50,000 messages, while the node's own working set
# varies by a few MiB.
MIN_SENT_SHARE = 0.1
MIN_RATE_SHARE = 0.25
MAX_RSS_GROWTH_MIB = 32.0
SERVICE_DEADLINE_S = 10.0


class Load(unittest.TestCase):
    def test_a_flood_of_wind_and_grasps_leaves_the_node_running_in_bounded_memory(self):
        figures = load.measure(NODE, SECONDS, WIND_HZ, GRASP_HZ)
        text = load.report(figures, "the hanging scene at 20x20")
        print(text)
        self.assertGreaterEqual(figures["wind_sent_hz"], MIN_SENT_SHARE * WIND_HZ, text)
        self.assertGreaterEqual(figures["grasp_sent_hz"], MIN_SENT_SHARE * GRASP_HZ, text)
        self.assertGreaterEqual(figures["node_inputs"]["wind"]["received"], MIN_SENT_SHARE * WIND_HZ * SECONDS, text)
        self.assertGreaterEqual(figures["state_hz"], MIN_RATE_SHARE * FRAME_RATE_HZ, text)
        self.assertGreaterEqual(figures["frames_per_s"], MIN_RATE_SHARE * FRAME_RATE_HZ, text)
        self.assertGreaterEqual(figures["mesh_hz"], MIN_RATE_SHARE * FRAME_RATE_HZ, text)
        rss = figures["rss_mib"]
        self.assertLess(rss["peak"] - rss["before"], MAX_RSS_GROWTH_MIB, text)
        rospy.wait_for_service(NODE + "/pause", SERVICE_DEADLINE_S)
        self.assertTrue(rospy.ServiceProxy(NODE + "/pause", SetBool)(False).success)


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "load", Load)
