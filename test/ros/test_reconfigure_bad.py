#!/usr/bin/python3
"""dynamic_reconfigure values the node must refuse, sent with the Python client (which, unlike dynparam,
sends NaN): NaN, inf, negative and out-of-range numbers, a wind whose components are each allowed but
whose magnitude (173 m/s) is not. Each is refused as a whole: the answer is the previous configuration,
the node warns naming the field, and it keeps running. Before, the server clamped silently (-5 to 0,
inf to 1e4) and NaN went through. Run by test/ros/reconfigure_bad.test.
"""
import math
import threading
import unittest

import dynamic_reconfigure.client
import rospy
import rostest
from cloth_sim.msg import ClothState
from geometry_msgs.msg import Vector3Stamped
from rosgraph_msgs.msg import Log

NODE = "/cloth_node"
TIMEOUT_S = 20.0
FRAMES_ALIVE = 10
BLOWN_M = 0.02  # the bottom corner's y once a 3 m/s ~wind along +y blows (it hangs at y = 0)


class ReconfigureRefusals(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.logs = []
        cls.states = []
        rospy.Subscriber("/rosout", Log, cls._on_log, queue_size=1000)
        rospy.Subscriber(NODE + "/state", ClothState, cls._on_state, queue_size=10)
        cls.client = dynamic_reconfigure.client.Client(NODE + "/tuning", timeout=TIMEOUT_S)

    @classmethod
    def _on_log(cls, message):
        if message.name == NODE:
            with cls.lock:
                cls.logs.append(message.msg)

    @classmethod
    def _on_state(cls, message):
        with cls.lock:
            cls.states.append(message)

    def wait_for(self, condition, what):
        deadline = rospy.Time.now() + rospy.Duration(TIMEOUT_S)
        while not rospy.is_shutdown() and rospy.Time.now() < deadline:
            with self.lock:
                if condition():
                    return
            rospy.sleep(0.01)
        self.fail("timed out waiting for " + what)

    def expect_refused(self, changes, field):
        before = self.client.get_configuration(timeout=TIMEOUT_S)
        with self.lock:
            log_start = len(self.logs)
        answer = self.client.update_configuration(changes)
        for name in changes:
            self.assertEqual(answer[name], before[name],
                             "%s: answered %r where %r was in force (clamped or taken?)" % (name, answer[name],
                                                                                            before[name]))
        self.wait_for(lambda: any("reconfigure refused: " + field in m for m in self.logs[log_start:]),
                      "a warning naming " + field)
        # Alive: FRAMES_ALIVE more states arrive (the last of them certainly published after the answer)
        # and the cloth advances.
        with self.lock:
            received = len(self.states)
            frame = self.states[-1].frame if self.states else 0
        self.wait_for(lambda: len(self.states) >= received + FRAMES_ALIVE and self.states[-1].frame > frame,
                      "the cloth to advance after the refusal")
        with self.lock:
            state = self.states[-1]
        self.assertTrue(math.isfinite(state.kinetic_energy))
        after = self.client.get_configuration(timeout=TIMEOUT_S)
        for name in changes:
            self.assertEqual(after[name], before[name], name + " changed after all")

    def test_a_nan_stiffness_is_refused(self):
        self.expect_refused({"structural_stiffness": float("nan")}, "structural_stiffness")

    def test_an_infinite_damping_is_refused_not_clamped(self):
        self.expect_refused({"air_damping": float("inf")}, "air_damping")

    def test_a_negative_damping_is_refused_not_clamped_to_zero(self):
        self.expect_refused({"shear_damping": -5.0}, "shear_damping")

    def test_a_stiffness_over_the_limit_is_refused(self):
        self.expect_refused({"bend_stiffness": 1e8}, "bend_stiffness")

    def test_negative_substeps_are_refused_not_clamped_to_one(self):
        self.expect_refused({"substeps": -5}, "substeps")

    def test_a_wind_of_173_metres_per_second_is_refused(self):
        self.expect_refused({"wind_x": 100.0, "wind_y": 100.0, "wind_z": 100.0}, "wind_x, wind_y, wind_z")

    def test_a_nan_wind_is_refused(self):
        self.expect_refused({"wind_y": float("nan")}, "wind_y")

    def test_a_valid_change_is_taken_and_the_ranges_are_published(self):
        # Control for the refusals above, and the ranges rqt_reconfigure shows come from OptionLimits.
        answer = self.client.update_configuration({"substeps": 3})
        self.assertEqual(answer["substeps"], 3)
        self.wait_for(lambda: self.states and self.states[-1].substeps == 3, "substeps 3 in ~state")
        self.assertEqual(self.client.update_configuration({"substeps": 1})["substeps"], 1)
        self.wait_for(lambda: self.states and self.states[-1].substeps == 1, "substeps 1 in ~state")
        ranges = {d["name"]: (d["min"], d["max"]) for d in self.client.get_parameter_descriptions(timeout=TIMEOUT_S)}
        self.assertEqual(ranges["structural_stiffness"], (0.0, 1e7))
        self.assertEqual(ranges["wind_x"], (-100.0, 100.0))
        self.assertEqual(ranges["substeps"], (0, 10000))  # 0: auto
        # The defaults clients read are the README's (a scene that names neither: implicit_euler, auto).
        defaults = {d["name"]: d["default"] for d in self.client.get_parameter_descriptions(timeout=TIMEOUT_S)}
        self.assertEqual(defaults["integrator"], "implicit_euler")
        self.assertEqual(defaults["substeps"], 0)

    def test_z_setting_a_wind_slider_to_what_it_shows_stops_a_wind_message(self):
        # An audit's: after a ~wind of 3 m/s the sliders still read 0, and `dynparam set ... wind_y 0` was
        # no change: the answer read 3 and the wind blew on. A request that changes no slider now sets the
        # wind to the sliders'. Last (z): it changes the wind the refusals above compare.
        wind = rospy.Publisher(NODE + "/wind", Vector3Stamped, queue_size=1, latch=True)
        message = Vector3Stamped()
        message.vector.y = 3.0
        wind.publish(message)
        self.wait_for(lambda: self.states and self.states[-1].positions[-1].y > BLOWN_M,
                      "the ~wind to blow the cloth along +y")
        self.assertEqual(self.client.get_configuration(timeout=TIMEOUT_S)["wind_y"], 0.0)
        answer = self.client.update_configuration({"wind_y": 0.0})
        self.assertEqual(answer["wind_y"], 0.0, "setting wind_y 0 left the ~wind's 3 m/s in force")
        wind.unregister()

if __name__ == "__main__":
    rospy.init_node("test_reconfigure_bad")
    rostest.rosrun("cloth_sim", "reconfigure_bad", ReconfigureRefusals)
