#!/usr/bin/python3
"""~points and the simulated depth cameras under rostest (issue 16), against test/ros/cameras.test.

- Nothing builds ~points while nobody subscribes (the diagnostics' "point clouds built" stays 0); once
  subscribed it has rows x cols finite points with colours.
- ~front's depth image, camera info, mask and organised cloud agree with each other, and depth_image_proc's
  point_cloud_xyz, fed the image and the info, gives the same points as ~front/depth/points.
- A camera whose tf frame does not exist is reported by name in the diagnostics and the node keeps
  publishing (its other camera included).
Every wait is a condition with a deadline.
"""
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
from cloth_sim.msg import ClothState
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from sensor_msgs.msg import CameraInfo, Image, PointCloud2

NODE = "/cloth_node"
ROWS = COLS = 20  # the drape scene's grid
WIDTH, HEIGHT = 160, 120  # the front camera's image (cameras.test)
FX = FY = 131.25
DEADLINE_S = 30.0


class Latest:
    """Keeps the messages of one topic and lets a test wait for one that satisfies a condition."""

    def __init__(self, topic, message_type):
        self.condition = threading.Condition()
        self.messages = []
        self.subscriber = rospy.Subscriber(topic, message_type, self.received, queue_size=10)

    def received(self, message):
        with self.condition:
            self.messages.append(message)
            del self.messages[:-20]  # bounded: the last 20 only
            self.condition.notify_all()

    def wait_for(self, predicate=lambda message: True, timeout_s=DEADLINE_S):
        deadline = time.monotonic() + timeout_s
        with self.condition:
            while True:
                for message in reversed(self.messages):
                    if predicate(message):
                        return message
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.condition.wait(left)

    def close(self):
        self.subscriber.unregister()


def cameras_status(array):
    for status in array.status:
        if status.name.endswith("cameras"):
            return status
    return None


def value_of(status, key):
    for pair in status.values:
        if pair.key == key:
            return pair.value
    return None


def cloud_array(cloud, names):
    """The named float32 fields of a PointCloud2 as an (points, len(names)) array."""
    offsets = {field.name: field.offset for field in cloud.fields}
    dtype = np.dtype({"names": names, "formats": ["<f4"] * len(names), "offsets": [offsets[n] for n in names],
                      "itemsize": cloud.point_step})
    points = np.frombuffer(bytes(cloud.data), dtype=dtype, count=cloud.width * cloud.height)
    return np.stack([points[n] for n in names], axis=1)


class Cameras(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_cameras")
        cls.diagnostics = Latest("/diagnostics", DiagnosticArray)

    def test_1_points_are_built_only_while_subscribed(self):
        # Nobody has subscribed to ~points yet: the node reports it built none.
        idle = self.diagnostics.wait_for(lambda a: cameras_status(a) is not None)
        self.assertIsNotNone(idle, "no cameras diagnostics")
        self.assertEqual(value_of(cameras_status(idle), "point clouds built"), "0")

        points = Latest(NODE + "/points", PointCloud2)
        cloud = points.wait_for()
        points.close()
        self.assertIsNotNone(cloud, "no ~points within the deadline")
        self.assertEqual((cloud.height, cloud.width), (ROWS, COLS))
        self.assertEqual(cloud.header.frame_id, "world")
        self.assertEqual([f.name for f in cloud.fields], ["x", "y", "z", "rgb"])
        xyz = cloud_array(cloud, ["x", "y", "z"])
        self.assertEqual(xyz.shape, (ROWS * COLS, 3))
        self.assertTrue(np.isfinite(xyz).all())
        offsets = {field.name: field.offset for field in cloud.fields}
        rgb = np.frombuffer(bytes(cloud.data), dtype=np.dtype({"names": ["rgb"], "formats": ["<u4"],
                                                                "offsets": [offsets["rgb"]],
                                                                "itemsize": cloud.point_step}))["rgb"]
        self.assertTrue((rgb >> 24 == 0).all(), "rgb packs 0x00RRGGBB")
        self.assertGreater(len(np.unique(rgb)), 1, "the checker texture gives more than one colour")
        built = self.diagnostics.wait_for(
            lambda a: cameras_status(a) is not None and int(value_of(cameras_status(a), "point clouds built")) > 0)
        self.assertIsNotNone(built, "the diagnostics never counted the clouds built")

    def test_2_depth_image_info_mask_and_cloud_agree(self):
        depth = Latest(NODE + "/front/depth/image_raw", Image)
        info = Latest(NODE + "/front/depth/camera_info", CameraInfo)
        mask = Latest(NODE + "/front/mask", Image)
        ours = Latest(NODE + "/front/depth/points", PointCloud2)
        theirs = Latest("/xyz/points", PointCloud2)
        try:
            image = depth.wait_for()
            self.assertIsNotNone(image, "no depth image")
            self.assertEqual((image.encoding, image.width, image.height, image.step),
                             ("32FC1", WIDTH, HEIGHT, 4 * WIDTH))
            self.assertEqual(image.header.frame_id, "front_optical")
            camera_info = info.wait_for()
            self.assertEqual((camera_info.width, camera_info.height), (WIDTH, HEIGHT))
            self.assertEqual(list(camera_info.K), [FX, 0, (WIDTH - 1) / 2, 0, FY, (HEIGHT - 1) / 2, 0, 0, 1])

            # The mask marks exactly the pixels the cloth fills (the drape scene has no colliders).
            pair = None
            deadline = time.monotonic() + DEADLINE_S
            while pair is None and time.monotonic() < deadline:
                m = mask.wait_for(timeout_s=1.0)
                if m is None:
                    continue
                d = depth.wait_for(lambda x: x.header.stamp == m.header.stamp, timeout_s=1.0)
                if d is not None:
                    pair = (d, m)
            self.assertIsNotNone(pair, "no depth image and mask of the same instant")
            depth_m = np.frombuffer(bytes(pair[0].data), dtype="<f4").reshape(HEIGHT, WIDTH)
            cloth = np.frombuffer(bytes(pair[1].data), dtype=np.uint8).reshape(HEIGHT, WIDTH)
            self.assertEqual(pair[1].encoding, "mono8")
            self.assertGreater(np.isfinite(depth_m).sum(), 1000, "the cloth should fill a good part of the image")
            np.testing.assert_array_equal(cloth == 255, np.isfinite(depth_m))
            self.assertTrue(set(np.unique(cloth)) <= {0, 255})
            finite = depth_m[np.isfinite(depth_m)]
            # The cloth hangs about 2 m in front of the camera (it sways a little as it settles).
            self.assertTrue(((finite > 1.5) & (finite < 2.5)).all(), (finite.min(), finite.max()))

            # depth_image_proc's point_cloud_xyz against ~front/depth/points, matched by stamp.
            match = None
            deadline = time.monotonic() + DEADLINE_S
            while match is None and time.monotonic() < deadline:
                t = theirs.wait_for(timeout_s=1.0)
                if t is None:
                    continue
                o = ours.wait_for(lambda c: c.header.stamp == t.header.stamp, timeout_s=1.0)
                if o is not None:
                    match = (o, t)
            self.assertIsNotNone(match, "no clouds of the same instant from the node and depth_image_proc")
            a = cloud_array(match[0], ["x", "y", "z"])
            b = cloud_array(match[1], ["x", "y", "z"])
            self.assertEqual((match[0].width, match[0].height), (match[1].width, match[1].height))
            self.assertEqual(match[0].header.frame_id, match[1].header.frame_id)
            np.testing.assert_array_equal(np.isnan(a), np.isnan(b))
            self.assertGreater(np.isfinite(a[:, 2]).sum(), 1000)
            np.testing.assert_allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-6, atol=1e-6)
        finally:
            for latest in (depth, info, mask, ours, theirs):
                latest.close()

    def test_3_an_unknown_frame_is_reported_by_name_and_the_node_keeps_running(self):
        lost = Latest(NODE + "/lost/depth/image_raw", Image)  # makes "lost" try to render
        try:
            reported = self.diagnostics.wait_for(
                lambda a: cameras_status(a) is not None and "no_such_frame" in cameras_status(a).message)
            self.assertIsNotNone(reported, "the unknown frame was never reported")
            status = cameras_status(reported)
            self.assertEqual(status.level, DiagnosticStatus.WARN)
            self.assertIn("camera 'lost'", status.message)
            self.assertIsNone(lost.wait_for(timeout_s=1.0), "a camera without a pose published an image")
        finally:
            lost.close()
        states = Latest(NODE + "/state", ClothState)
        first = states.wait_for()
        self.assertIsNotNone(first, "the node stopped publishing ~state")
        later = states.wait_for(lambda s: s.frame > first.frame)
        self.assertIsNotNone(later, "the node stopped advancing")
        states.close()
        front = Latest(NODE + "/front/depth/image_raw", Image)
        self.assertIsNotNone(front.wait_for(), "the good camera stopped")
        front.close()


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "cameras", Cameras)
