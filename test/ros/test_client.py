#!/usr/bin/python3
"""The tutorial's client (examples/cloth_client.py) runs end to end against a live cloth_node.

Runs the client as a user would, checks that it exits 0, that the dragged corner followed the hand
(the 'held ... error' line below 5 cm) and that it let go. Run by test/ros/client.test.
"""
import os
import re
import subprocess
import unittest

import rospy
import rostest

CLIENT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples", "cloth_client.py")
TIMEOUT_S = 60.0
FOLLOW_ERROR_M = 0.05


class Client(unittest.TestCase):
    def test_the_tutorial_client_drags_the_corner_and_lets_go(self):
        done = subprocess.run([CLIENT, "--node", "/cloth_node", "--wind", "3", "--seconds", "1"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=TIMEOUT_S)
        output = done.stdout.decode(errors="replace")
        self.assertEqual(done.returncode, 0, output[-2000:])
        held = re.search(r"held [0-9.]+ s at the last target: error ([0-9.]+) m", output)
        self.assertIsNotNone(held, output[-2000:])
        self.assertLess(float(held.group(1)), FOLLOW_ERROR_M, output[-2000:])
        self.assertIn("released", output)


if __name__ == "__main__":
    rospy.init_node("test_client")
    rostest.rosrun("cloth_sim", "client", Client)
