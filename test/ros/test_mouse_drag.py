#!/usr/bin/python3
"""The paper's mouse (§5) in rviz: cloth_node's interactive marker drives the cloth's grasps.

test/ros/mouse_drag.test runs cloth_node on the hanging scene (20 x 20, top corners pinned). This test
does what rviz does when a user clicks the cloth and drags: it waits for the marker on ~mouse/update_full,
then sends InteractiveMarkerFeedback on ~mouse/feedback: MOUSE_DOWN at the free bottom-left corner, then
POSE_UPDATEs moving the marker 0.3 m up and 0.3 m out of the cloth's plane, then MOUSE_UP. The corner must
follow the mouse there, and fall once let go.
"""
import math
import os
import tempfile
import threading
import time
import unittest

import rospy
import rostest
from cloth_sim.msg import ClothState
from cloth_sim.srv import LoadState, SaveState
from geometry_msgs.msg import Point, TransformStamped
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import InteractiveMarkerFeedback, InteractiveMarkerInit

DEADLINE_S = 20.0
ROWS, COLS = 20, 20
CORNER = (ROWS - 1) * COLS  # bottom-left, free
OTHER_CORNER = ROWS * COLS - 1  # bottom-right, free
DRAG = (0.0, 0.3, 0.3)  # m, world frame: how far the mouse moves the marker
# The mouse's grasp uses the scene's grasp_stiffness, 50 N/m: holding part of the cloth's 4.9 N weight it
# sits up to 0.1 m short of the target; 0.15 m leaves room for the swing. The corner starts 0.42 m away.
TOLERANCE_M = 0.15
NOT_FOLLOWED_S = 5.0  # s: a grab follows the mouse within a second or two (the test below)
CLIENT_ID = "/test_mouse_drag"
SHIFTED_FRAME = "shifted"  # a frame 1 m to the side of the node's: rviz's fixed frame need not be the node's
SHIFT_M = 1.0


def distance(a, b):
    return math.sqrt((a.x - b.x) ** 2 + (a.y - b.y) ** 2 + (a.z - b.z) ** 2)


class States:
    def __init__(self):
        self.lock = threading.Lock()
        self.latest = None
        self.subscriber = rospy.Subscriber("/cloth_node/state", ClothState, self.on_state, queue_size=5)

    def on_state(self, state):
        with self.lock:
            self.latest = state

    def wait_for(self, condition, deadline_s=DEADLINE_S, keep_doing=None):
        deadline = time.monotonic() + deadline_s
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if keep_doing is not None:
                keep_doing()
            with self.lock:
                if self.latest is not None and condition(self.latest):
                    return self.latest
            time.sleep(0.1)
        return None


class MouseDrag(unittest.TestCase):
    def setUp(self):
        self.states = States()
        self.markers = []
        self.init_subscriber = rospy.Subscriber("/cloth_node/mouse/update_full", InteractiveMarkerInit,
                                                self.markers.append, queue_size=2)
        self.feedback = rospy.Publisher("/cloth_node/mouse/feedback", InteractiveMarkerFeedback, queue_size=10)
        self.tf_static = rospy.Publisher("/tf_static", TFMessage, queue_size=1, latch=True)

    def feedback_message(self, event_type, marker_position=(0.0, 0.0, 0.0), mouse_point=None):
        message = InteractiveMarkerFeedback()
        message.header.frame_id = "world"
        message.client_id = CLIENT_ID
        message.marker_name = "cloth"
        message.control_name = "drag"
        message.event_type = event_type
        message.pose.position = Point(*marker_position)
        message.pose.orientation.w = 1.0
        if mouse_point is not None:
            message.mouse_point = mouse_point
            message.mouse_point_valid = True
        return message

    def free_corner(self):
        """Where the free corner is once the node listens to the mouse (in `world`)."""
        deadline = time.monotonic() + DEADLINE_S
        while time.monotonic() < deadline and self.feedback.get_num_connections() == 0:
            time.sleep(0.05)
        start = self.states.wait_for(lambda s: True)
        self.assertIsNotNone(start, "no ~state")
        return start.positions[CORNER]

    def drag_the_corner(self):
        """Clicks the free corner and drags it by DRAG until it follows: (target, the drag's update, the
        state that followed it). The later checks of a test then prove something about a live drag."""
        corner = self.free_corner()
        clicked = Point(corner.x + 0.01, corner.y, corner.z + 0.01)
        target = Point(clicked.x + DRAG[0], clicked.y + DRAG[1], clicked.z + DRAG[2])
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_DOWN, mouse_point=clicked))
        drag = self.feedback_message(InteractiveMarkerFeedback.POSE_UPDATE, marker_position=DRAG)
        followed = self.states.wait_for(lambda s: distance(s.positions[CORNER], target) < TOLERANCE_M,
                                        keep_doing=lambda: self.feedback.publish(drag))
        self.assertIsNotNone(followed, "the corner never followed the drag: the test would prove nothing")
        return target, drag, followed

    def test_a_drag_whose_mouse_down_was_dropped_grabs_nothing(self):
        # The mouse-down names a frame tf does not know, so the node drops its grab; pose updates in
        # another frame must not grab the cloth after all (they did: the corner followed them).
        corner = self.free_corner()
        clicked = Point(corner.x + 0.01, corner.y, corner.z + 0.01)
        target = Point(clicked.x + DRAG[0], clicked.y + DRAG[1], clicked.z + DRAG[2])
        down = self.feedback_message(InteractiveMarkerFeedback.MOUSE_DOWN, mouse_point=clicked)
        down.header.frame_id = "no_such_frame"
        self.feedback.publish(down)
        drag = self.feedback_message(InteractiveMarkerFeedback.POSE_UPDATE, marker_position=DRAG)
        # The same wait in which the test below sees the corner follow a drag.
        followed = self.states.wait_for(lambda s: distance(s.positions[CORNER], target) < TOLERANCE_M,
                                        deadline_s=NOT_FOLLOWED_S, keep_doing=lambda: self.feedback.publish(drag))
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP, marker_position=DRAG))
        self.assertIsNone(followed, "the corner followed a drag whose grab was dropped")

    def test_a_click_in_another_frame_grabs_the_particle_under_it(self):
        # An audit's: the node picked the clicked particle from the click's coordinates as if they were in
        # its own frame, so a click on the bottom-left corner given in a frame 1 m to the side grabbed the
        # bottom-right one. rviz sends the feedback in its fixed frame, which need not be the node's.
        shifted = TransformStamped()
        shifted.header.frame_id = "world"
        shifted.header.stamp = rospy.Time.now()
        shifted.child_frame_id = SHIFTED_FRAME
        shifted.transform.translation.x = -SHIFT_M  # its origin 1 m along -x: a point's x there is x + 1 m
        shifted.transform.rotation.w = 1.0
        self.tf_static.publish(TFMessage([shifted]))
        corner = self.free_corner()
        clicked = Point(corner.x + 0.01 + SHIFT_M, corner.y, corner.z + 0.01)  # the corner, in SHIFTED_FRAME
        target = Point(corner.x + 0.01 + DRAG[0], corner.y + DRAG[1], corner.z + 0.01 + DRAG[2])  # world
        down = self.feedback_message(InteractiveMarkerFeedback.MOUSE_DOWN, mouse_point=clicked)
        down.header.frame_id = SHIFTED_FRAME
        # The marker stands at the node's origin: (1, 0, 0) in the shifted frame.
        down.pose.position = Point(SHIFT_M, 0.0, 0.0)
        drag = self.feedback_message(InteractiveMarkerFeedback.POSE_UPDATE,
                                     marker_position=(SHIFT_M + DRAG[0], DRAG[1], DRAG[2]))
        drag.header.frame_id = SHIFTED_FRAME
        up = self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP)
        up.header.frame_id = SHIFTED_FRAME
        # tf may take a moment to hear of the frame: the whole click (up, down, drag) is sent again until
        # the corner follows, each time picking afresh.
        followed = self.states.wait_for(lambda s: distance(s.positions[CORNER], target) < TOLERANCE_M,
                                        keep_doing=lambda: (self.feedback.publish(up), self.feedback.publish(down),
                                                            self.feedback.publish(drag)))
        self.feedback.publish(up)
        last = self.states.latest.positions[CORNER]
        self.assertIsNotNone(followed, "the clicked corner stayed %.3f m from the mouse's target"
                             % distance(last, target))

    def test_a_reset_ends_the_drag_and_its_later_updates_grab_nothing(self):
        # An audit's: ~reset released the mouse's grasp (id 4294967295), and the drag's next pose update
        # grabbed the corner again. The drag follows first, so the test proves the drag was live.
        target, drag, followed = self.drag_the_corner()
        rospy.wait_for_service("/cloth_node/reset", timeout=DEADLINE_S)
        answer = rospy.ServiceProxy("/cloth_node/reset", Trigger)()
        self.assertTrue(answer.success, answer.message)
        self.assertIn("released grasp ids 4294967295", answer.message)
        # The states from before the reset may still be arriving (the corner at the target): wait for the
        # reset's own first, so that the check below reads only the cloth after it.
        self.assertIsNotNone(self.states.wait_for(lambda s: s.frame < followed.frame),
                             "no state from after the reset")
        # The same wait in which the corner follows a live drag.
        again = self.states.wait_for(lambda s: distance(s.positions[CORNER], target) < TOLERANCE_M,
                                     deadline_s=NOT_FOLLOWED_S, keep_doing=lambda: self.feedback.publish(drag))
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP, marker_position=DRAG))
        self.assertIsNone(again, "after ~reset the drag's updates grabbed the corner again")

    def test_after_a_state_saved_mid_drag_is_loaded_a_click_drags_the_clicked_particle(self):
        # An audit's: the file restored the mouse's grasp (id 4294967295) on the bottom-left corner, and the
        # next mouse-down's GRAB of that id only moved its target: a click on the bottom-right corner dragged
        # the bottom-left one across the cloth. The restored grasp is let go at the next mouse-down.
        rospy.wait_for_service("/cloth_node/save_state", timeout=DEADLINE_S)
        save = rospy.ServiceProxy("/cloth_node/save_state", SaveState)
        load = rospy.ServiceProxy("/cloth_node/load_state", LoadState)
        target, drag, followed = self.drag_the_corner()
        path = os.path.join(tempfile.mkdtemp(prefix="test_mouse_drag_"), "mid_drag.state")
        saved = save(path)
        self.assertTrue(saved.success, saved.message)
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP, marker_position=DRAG))
        loaded = load(path)
        self.assertTrue(loaded.success, loaded.message)
        self.assertIn("1 grasps", loaded.message, "the file does not hold the mouse's grasp: the test would prove nothing")
        # A new drag from the bottom-right corner, towards the middle of the cloth's bottom edge.
        start = self.states.wait_for(lambda s: True)
        self.assertIsNotNone(start, "no ~state after the load")
        other = start.positions[OTHER_CORNER]
        other_clicked = Point(other.x - 0.01, other.y, other.z + 0.01)
        other_target = Point(other_clicked.x - 0.3, other_clicked.y + 0.3, other_clicked.z + 0.3)
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_DOWN, mouse_point=other_clicked))
        other_drag = self.feedback_message(InteractiveMarkerFeedback.POSE_UPDATE, marker_position=(-0.3, 0.3, 0.3))
        moved = self.states.wait_for(lambda s: distance(s.positions[OTHER_CORNER], other_target) < TOLERANCE_M,
                                     keep_doing=lambda: self.feedback.publish(other_drag))
        last = self.states.latest
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP, marker_position=(-0.3, 0.3, 0.3)))
        self.assertIsNotNone(moved, "the clicked corner stayed %.3f m from its target; the file's corner is %.3f m "
                             "from it" % (distance(last.positions[OTHER_CORNER], other_target),
                                          distance(last.positions[CORNER], other_target)))
        self.assertGreater(distance(moved.positions[CORNER], other_target), TOLERANCE_M,
                           "the file's corner was dragged to the new click's target")

    def test_click_drag_and_let_go_moves_the_clicked_particle(self):
        deadline = time.monotonic() + DEADLINE_S
        while time.monotonic() < deadline and not (self.markers and self.feedback.get_num_connections() > 0):
            time.sleep(0.05)
        self.assertTrue(self.markers, "no interactive marker on /cloth_node/mouse/update_full")
        self.assertIn("cloth", [m.name for m in self.markers[-1].markers])
        self.assertGreater(self.feedback.get_num_connections(), 0, "nobody listens on ~mouse/feedback")
        start = self.states.wait_for(lambda s: True)
        self.assertIsNotNone(start, "no ~state")
        corner = start.positions[CORNER]
        clicked = Point(corner.x + 0.01, corner.y, corner.z + 0.01)  # on the cloth, nearest to the corner
        target = Point(clicked.x + DRAG[0], clicked.y + DRAG[1], clicked.z + DRAG[2])

        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_DOWN, mouse_point=clicked))
        drag = self.feedback_message(InteractiveMarkerFeedback.POSE_UPDATE, marker_position=DRAG)
        followed = self.states.wait_for(lambda s: distance(s.positions[CORNER], target) < TOLERANCE_M,
                                        keep_doing=lambda: self.feedback.publish(drag))
        last = self.states.latest.positions[CORNER]
        self.assertIsNotNone(followed, "the corner stayed %.3f m from the mouse's target" % distance(last, target))
        self.assertTrue(all(math.isfinite(c) for p in followed.positions for c in (p.x, p.y, p.z)))

        held_z = followed.positions[CORNER].z
        self.feedback.publish(self.feedback_message(InteractiveMarkerFeedback.MOUSE_UP, marker_position=DRAG))
        fallen = self.states.wait_for(lambda s: s.positions[CORNER].z < held_z - 0.1)
        self.assertIsNotNone(fallen, "let go at z = %.3f m, the corner stayed at z = %.3f m"
                             % (held_z, self.states.latest.positions[CORNER].z))


if __name__ == "__main__":
    rospy.init_node("test_mouse_drag")
    rostest.rosrun("cloth_sim", "mouse_drag", MouseDrag)
