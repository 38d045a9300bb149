#!/usr/bin/python3
"""The robot demo end to end (test/ros/robot_demo.test runs launch/robot.launch).

The towel (config/scenes/robot.yaml) lies on the table at 0.705 m. The driver attaches both grippers at 1 s
of its clock, lifts the towel to 1 m by 2 s and carries it over the table's edge and the forearm, and lets
go at 8 s. This test checks, through the real topics:
- the grippers' wrenches arrive in the grippers' frames and, once the towel hangs beyond the table's edge,
  carry its weight (0.1 kg) between them, pulling down;
- the towel is lifted clear of the table (its front corners above 0.95 m) and carried beyond the table's
  far edge (y > 0.5);
- after ~detach the wrenches stop, and then the towel falls (beyond the table, its highest particle below
  0.6 m).
"""
import threading
import time
import unittest

import rospy
import rostest
from cloth_sim.msg import ClothState
from geometry_msgs.msg import WrenchStamped

DEADLINE_S = 40.0
TOWEL_WEIGHT_N = 0.1 * 9.81
# A gripper's wrench comes with every frame (50 Hz): this long without one means it has let go, s.
DETACHED_SILENCE_S = 0.5
# Wrenches of each gripper averaged while the towel hangs beyond the table (half a second at 50 Hz).
WRENCH_WINDOW = 25


class RobotDemo(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.wrenches = {1: [], 2: []}
        self.last_wrench_s = {1: 0.0, 2: 0.0}
        self.states = []
        self.subscribers = [
            rospy.Subscriber("/cloth_node/gripper_%d/wrench" % k, WrenchStamped,
                             lambda m, k=k: self.store_wrench(k, m), queue_size=100) for k in (1, 2)]
        self.subscribers.append(rospy.Subscriber("/cloth_node/state", ClothState,
                                                 lambda m: self.store(self.states, m), queue_size=100))

    def store(self, into, message):
        with self.lock:
            into.append(message)

    def store_wrench(self, k, message):
        with self.lock:
            self.wrenches[k].append(message)
            self.last_wrench_s[k] = time.monotonic()

    def wait_for(self, condition):
        deadline = time.monotonic() + DEADLINE_S
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if condition():
                    return True
            time.sleep(0.1)
        return False

    def test_the_robot_picks_the_towel_up_carries_it_off_the_table_and_lets_go(self):
        def lifted():
            return any(s.positions[0].z > 0.95 and s.positions[19].z > 0.95 for s in self.states)
        self.assertTrue(self.wait_for(lifted), "the towel's front corners never rose above 0.95 m")
        with self.lock:
            for k, frame in ((1, "left_gripper"), (2, "right_gripper")):
                self.assertTrue(self.wrenches[k], "no ~gripper_%d/wrench" % k)
                self.assertEqual(self.wrenches[k][-1].header.frame_id, frame)

        def carried():
            return any(min(p.y for p in s.positions) > 0.5 for s in self.states)
        self.assertTrue(self.wait_for(carried), "the towel was never carried beyond the table's far edge")
        # Beyond the table's edge the towel hangs from the grippers alone: over their next WRENCH_WINDOW
        # wrenches each (counted, not timed: a loaded machine publishes fewer a second) they carry its weight
        # between them, pulling down (the frames are level: force.z is world z). Swinging adds and takes a
        # little, so the mean is compared with a margin.
        with self.lock:
            first = [len(self.wrenches[1]), len(self.wrenches[2])]
        self.assertTrue(self.wait_for(lambda: all(len(self.wrenches[k]) - first[k - 1] >= WRENCH_WINDOW
                                                  for k in (1, 2))),
                        "fewer than %d wrenches from each gripper while the towel hung" % WRENCH_WINDOW)
        with self.lock:
            sums = [sum(w.wrench.force.z for w in self.wrenches[k][first[k - 1]:first[k - 1] + WRENCH_WINDOW]) /
                    WRENCH_WINDOW for k in (1, 2)]
        self.assertLess(sum(sums), -0.6 * TOWEL_WEIGHT_N, "the grippers' pulls %s" % sums)
        self.assertGreater(sum(sums), -1.6 * TOWEL_WEIGHT_N, "the grippers' pulls %s" % sums)

        # ~detach: both grippers stop publishing their wrenches (for longer than a few of their periods).
        def detached():
            return all(self.wrenches[k] and time.monotonic() - self.last_wrench_s[k] > DETACHED_SILENCE_S
                       for k in (1, 2))
        self.assertTrue(self.wait_for(detached), "a detached gripper still publishes its wrench")
        with self.lock:
            first_after = len(self.states)

        # Then, and only then, the towel falls off the forearm onto the floor beyond the table: lowered
        # far enough, it may slip over the forearm while still held, which is not a fall after ~detach.
        def let_go():
            return any(min(p.y for p in s.positions) > 0.5 and max(p.z for p in s.positions) < 0.6
                       for s in self.states[first_after:])
        fell = self.wait_for(let_go)
        with self.lock:
            last = self.states[-1]
        self.assertTrue(fell, "the towel never fell after ~detach: at the end its highest particle at z %.3f m, "
                        "its nearest to the table at y %.3f m" % (max(p.z for p in last.positions),
                                                                   min(p.y for p in last.positions)))


if __name__ == "__main__":
    rospy.init_node("test_robot_demo")
    rostest.rosrun("cloth_sim", "robot_demo", RobotDemo)
