#!/usr/bin/python3
"""cloth.launch camera:=true (test/ros/camera_launch.test): ~front's depth image shows the cloth (finite
depths about 2 m away, where the mask says cloth), in the front_optical frame. Waits have deadlines.
Also what cloth.launch gives its nodes for other arguments, read with roslaunch's own dumps."""
import subprocess
import unittest

import numpy as np
import rospy
import rostest
from sensor_msgs.msg import Image

NODE = "/cloth_node"
DEADLINE_S = 30.0


class CameraLaunch(unittest.TestCase):
    def test_the_front_camera_sees_the_cloth(self):
        rospy.init_node("test_camera_launch")
        depth = rospy.wait_for_message(NODE + "/front/depth/image_raw", Image, timeout=DEADLINE_S)
        mask = rospy.wait_for_message(NODE + "/front/mask", Image, timeout=DEADLINE_S)
        self.assertEqual((depth.encoding, depth.width, depth.height), ("32FC1", 640, 480))
        self.assertEqual(depth.header.frame_id, "front_optical")
        depth_m = np.frombuffer(bytes(depth.data), dtype="<f4")
        seen = depth_m[np.isfinite(depth_m)]
        self.assertGreater(seen.size, 20000, "the cloth should fill a good part of the image")
        self.assertTrue(((seen > 1.5) & (seen < 2.5)).all(), (seen.min(), seen.max()))
        self.assertGreater(int((np.frombuffer(bytes(mask.data), dtype=np.uint8) == 255).sum()), 20000)


    def test_rviz_takes_frame_id_as_its_fixed_frame(self):
        # config/cloth.rviz says world: with another frame_id rviz showed nothing, its Global Status Error.
        command = subprocess.run(["roslaunch", "--args", "rviz", "cloth_sim", "cloth.launch", "rviz:=true",
                                  "frame_id:=cloth_frame"], capture_output=True, text=True, timeout=DEADLINE_S)
        self.assertIn("-f cloth_frame", command.stdout, command.stdout + command.stderr)

    def test_parent_frame_none_publishes_no_parent(self):
        # roslaunch drops an empty parent_frame:= on the command line, so "none" says it.
        for argument, expected in (("parent_frame:=none", "''"), ("parent_frame:=odom", "odom")):
            command = subprocess.run(["roslaunch", "--dump-params", "cloth_sim", "cloth.launch", argument],
                                     capture_output=True, text=True, timeout=DEADLINE_S)
            self.assertIn("/cloth_node/parent_frame_id: " + expected, command.stdout, argument)


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "camera_launch", CameraLaunch)
