#!/usr/bin/python3
"""A camera is posed from tf at its image's time (test/ros/camera_pose.test, under /use_sim_time).

The test owns /clock. The camera's optical frame moves away from the cloth along -y at 0.1 m/s: tf gets
two samples (t = 0 and t = 8 s) and interpolates between them, so the pose at any stamp is exact. The
cloth (the hanging scene's, with no gravity and no pins) rests in the plane y = 0, so the centre pixel's
depth is 2 + 0.1 t at the image's stamp t; a pose one frame (0.02 s) off would be 2 mm off. Every wait is
a condition with a deadline.
"""
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from geometry_msgs.msg import TransformStamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image
from tf2_msgs.msg import TFMessage

NODE = "/cloth_node"
WIDTH, HEIGHT = 33, 25  # centre pixel (16, 12) on the optical axis
SPEED_M_PER_S = 0.1
START_DISTANCE_M = 2.0
FIRST_S, LAST_S, STEP_S = 1.0, 5.0, 0.02
DEADLINE_S = 20.0
TOLERANCE_M = 1e-3


def camera_sample(t):
    sample = TransformStamped()
    sample.header.stamp = rospy.Time.from_sec(t)
    sample.header.frame_id = "world"
    sample.child_frame_id = "moving_optical"
    sample.transform.translation.x = 0.0
    sample.transform.translation.y = -(START_DISTANCE_M + SPEED_M_PER_S * t)
    sample.transform.translation.z = 1.0  # level with the cloth's centre (z from 0.5 to 1.5)
    # z forward along world +y, x along +x, y along -z: -90 degrees about x.
    sample.transform.rotation.x = -0.7071067811865476
    sample.transform.rotation.w = 0.7071067811865476
    return sample


def wait_until(condition, timeout_s=DEADLINE_S):
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


class CameraPose(unittest.TestCase):
    def test_each_image_is_posed_at_its_stamp(self):
        rospy.init_node("test_camera_pose")
        clock = rospy.Publisher("/clock", Clock, queue_size=10)
        tf = rospy.Publisher("/tf", TFMessage, queue_size=10)
        lock = threading.Lock()
        seen = {}

        def on_image(image):
            depth = np.frombuffer(bytes(image.data), dtype="<f4").reshape(HEIGHT, WIDTH)
            with lock:
                seen[image.header.stamp.to_sec()] = float(depth[HEIGHT // 2, WIDTH // 2])

        images = rospy.Subscriber(NODE + "/moving/depth/image_raw", Image, on_image, queue_size=100)
        self.assertTrue(wait_until(lambda: clock.get_num_connections() > 0 and tf.get_num_connections() > 0 and
                                   images.get_num_connections() > 0), "the node never connected")
        tf.publish(TFMessage(transforms=[camera_sample(0.0)]))
        tf.publish(TFMessage(transforms=[camera_sample(8.0)]))
        t = FIRST_S
        while t <= LAST_S:
            clock.publish(Clock(clock=rospy.Time.from_sec(t)))
            time.sleep(0.01)  # paces the simulated clock (2x real time); nothing waits on it
            t += STEP_S
        self.assertTrue(wait_until(lambda: len(seen) >= 20), "fewer than 20 images: %d" % len(seen))
        with lock:
            stamps = sorted(seen)
            checked = 0
            for stamp in stamps:
                expected = START_DISTANCE_M + SPEED_M_PER_S * stamp
                self.assertAlmostEqual(seen[stamp], expected, delta=TOLERANCE_M,
                                       msg="image at t = %.3f s: depth %.4f m, camera was %.4f m away" %
                                       (stamp, seen[stamp], expected))
                checked += 1
        self.assertGreater(stamps[-1] - stamps[0], 1.0, "the images should span the camera's motion")
        print("%d images from t = %.2f to %.2f s, each at its stamp's distance" % (checked, stamps[0], stamps[-1]))


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "camera_pose", CameraPose)
