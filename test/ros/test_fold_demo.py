#!/usr/bin/python3
"""The fold demo end to end (test/ros/fold_demo.test runs launch/fold.launch), and the pile in the node.

The `fold` scene's towel (24 x 24, 0.5 m) lies on the floor; the driver folds it in half through ~grasp
(the hands leave at 0.2 s of simulated time and let go at 2.2 s). Through the real topics:
- the hands lift the towel's last row (a corner rises above 0.15 m) and the node reports self-contacts;
- after letting go the moved half lies on the other: every particle of it above its mirror particle, and
  on average within three thicknesses of it;
- the `pile` scene loads through ~load_scene and runs, its cloth ending draped over the ball.
"""
import threading
import time
import unittest

import rospy
import rostest
from cloth_sim.msg import ClothState
from cloth_sim.srv import LoadScene
from diagnostic_msgs.msg import DiagnosticArray

DEADLINE_S = 60.0
THICKNESS_M = 1.5 * (0.5 / 23) * 2 ** 0.5  # the default: 1.5 grid-cell diagonals
SETTLED_S = 5.0  # simulated: 2.8 s after the hands let go


class FoldDemo(unittest.TestCase):
    def setUp(self):
        self.lock = threading.Lock()
        self.states = []
        self.contacts = []
        self.stretch = []
        rospy.Subscriber("/cloth_node/state", ClothState, self.on_state, queue_size=100)
        rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=10)

    def on_state(self, message):
        with self.lock:
            self.states.append(message)

    def on_diagnostics(self, message):
        for status in message.status:
            for pair in status.values:
                if pair.key == "self-collision contacts":
                    with self.lock:
                        self.contacts.append(int(pair.value))
                if pair.key == "self-collision stretch ratio":
                    with self.lock:
                        self.stretch.append(float(pair.value))

    def wait_for(self, condition):
        deadline = time.monotonic() + DEADLINE_S
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with self.lock:
                if condition():
                    return True
            time.sleep(0.1)
        return False

    def test_the_towel_is_folded_in_half_and_stays_folded_then_the_pile_runs(self):
        self.assertTrue(self.wait_for(lambda: any(max(p.z for p in s.positions) > 0.15 for s in self.states)),
                        "the hands never lifted the towel")
        self.assertTrue(self.wait_for(lambda: self.states[-1].sim_time > SETTLED_S),
                        "the node never reached %.1f s of simulated time" % SETTLED_S)
        with self.lock:
            state = self.states[-1]
            contacts = list(self.contacts)
            stretch = list(self.stretch)
        self.assertTrue(any(c > 0 for c in contacts), "no self-collision contacts in the diagnostics: %s" % contacts)
        # The folded towel at rest is well within the stretch the guarantee allows.
        self.assertTrue(stretch and 0.0 < stretch[-1] < 1.0, "self-collision stretch ratio: %s" % stretch)
        rows, cols = state.rows, state.cols
        above = 0
        gap = 0.0
        moved = 0
        for r in range(rows - rows // 2, rows):
            for c in range(cols):
                mine = state.positions[r * cols + c]
                mirror = state.positions[(rows - 1 - r) * cols + c]
                above += 1 if mine.z > mirror.z else 0
                gap += ((mine.x - mirror.x) ** 2 + (mine.y - mirror.y) ** 2 + (mine.z - mirror.z) ** 2) ** 0.5
                moved += 1
        self.assertEqual(above, moved, "%d of %d moved particles lie above their mirror particle" % (above, moved))
        self.assertLess(gap / moved, 3.0 * THICKNESS_M, "the moved half is not on the other")

        rospy.wait_for_service("/cloth_node/load_scene", timeout=10.0)
        answer = rospy.ServiceProxy("/cloth_node/load_scene", LoadScene)(scene="pile")
        self.assertTrue(answer.success, answer.message)
        with self.lock:
            self.states = []
        self.assertTrue(self.wait_for(lambda: self.states and self.states[-1].rows == 32 and
                                      self.states[-1].sim_time > 2.0), "the pile never ran 2 s")
        with self.lock:
            state = self.states[-1]
        top = max(p.z for p in state.positions)
        self.assertGreater(top, 0.23, "the pile's cloth is not draped over the 24 cm ball")
        self.assertLess(top, 0.4, "the pile's cloth has not fallen")


if __name__ == "__main__":
    rospy.init_node("test_fold_demo")
    rostest.rosrun("cloth_sim", "fold_demo", FoldDemo)
