#!/usr/bin/python3
"""cloth.launch camera:=true (test/ros/camera_launch.test): ~front's depth image shows the cloth (finite
depths about 2 m away, where the mask says cloth), in the front_optical frame. Waits have deadlines."""
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


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "camera_launch", CameraLaunch)
