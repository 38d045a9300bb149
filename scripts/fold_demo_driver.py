#!/usr/bin/python3
"""The fold demo's two hands (launch/fold.launch): fold the `fold` scene's towel in half through ~grasp.

The same script as the core's ScriptedFold (include/cloth_sim/core/scripted_fold.h), which the tests and
`cloth_bench --fold` use: the hands take the two corners of the towel's last row at 0.2 s of simulated
time, carry them over the middle on a half circle (smoothstep, 1.6 s) over the first row's corners,
ending 1.5 self-collision thicknesses above them and pi/2 thicknesses short of them (the fold's loop
takes that much of the towel), or over where those corners are now if the fold has dragged them in
further than that (read from each ~state), hold 0.4 s and let go. It follows the node's simulated
time from the first ~state it sees (each ~state message moves the hands to where they are at the end of
the next frame), so it folds the same at any node speed and however late it starts. The towel's grid and thickness come from the first ~state: the towel lies
flat on its rest grid then, and the thickness is the default, 1.5 grid-cell diagonals (the driver reads
~thickness, default 0: that default).

Parameters (private): ~cloth_node (default /cloth_node), ~thickness (m, default 0), ~stiffness (N/m,
default 0: the scene's grasp_stiffness), ~loop (default false; true: ~reset and fold again every ~period
seconds of simulated time, default 8).
"""

import math

import rospy
from cloth_sim.msg import ClothState, Grasp
from std_srvs.srv import Trigger

START_S = 0.2
CARRY_S = 1.6
HOLD_S = 0.4
SET_DOWN_THICKNESSES = 1.5
LOOP_THICKNESSES = math.pi / 2  # the fold's loop takes pi h / 2 of the towel's length
THICKNESS_PER_DIAGONAL = 1.5
FIRST_GRASP_ID = 7001
FRAME_S = 0.02


def smoothstep(u):
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


def sub(a, b):
    return [a[k] - b[k] for k in range(3)]


def norm(a):
    return math.sqrt(sum(x * x for x in a))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


class FoldDriver:
    def __init__(self):
        node = rospy.get_param("~cloth_node", "/cloth_node").rstrip("/")
        self.thickness = float(rospy.get_param("~thickness", 0.0))
        self.stiffness = float(rospy.get_param("~stiffness", 0.0))
        self.loop = bool(rospy.get_param("~loop", False))
        self.period = float(rospy.get_param("~period", 8.0))
        self.reset_name = node + "/reset"
        self.rest = None
        self.start_s = None  # the node's simulated time when the driver first heard from it
        self.released = False
        self.grasp = rospy.Publisher(node + "/grasp", Grasp, queue_size=10)
        rospy.Subscriber(node + "/state", ClothState, self.on_state, queue_size=1)

    def learn_grid(self, state):
        points = [(p.x, p.y, p.z) for p in state.positions]
        rows, cols = state.rows, state.cols
        self.rest = points
        self.rows, self.cols = rows, cols
        self.held = [(rows - 1) * cols, rows * cols - 1]
        self.targets = [0, cols - 1]
        normal = cross(sub(points[cols - 1], points[0]), sub(points[(rows - 1) * cols], points[0]))
        length = norm(normal)
        self.normal = [x / length for x in normal]
        if self.thickness <= 0.0:
            self.thickness = THICKNESS_PER_DIAGONAL * norm(sub(points[cols + 1], points[0]))
        rospy.loginfo("fold_demo_driver: %dx%d towel, thickness %.4f m", rows, cols, self.thickness)

    def hands(self, t, points):
        """Where the hands are at time t, the towel's particles now at points."""
        angle = math.pi * smoothstep((t - START_S) / CARRY_S)
        set_down = SET_DOWN_THICKNESSES * self.thickness * angle / math.pi
        allowance = LOOP_THICKNESSES * self.thickness
        out = []
        for held, target in zip(self.held, self.targets):
            start, end = self.rest[held], self.rest[target]
            center = [(start[k] + end[k]) / 2.0 for k in range(3)]
            radius = sub(start, center)
            lift = math.sin(angle) * norm(radius) + set_down
            length = norm(radius)
            # How far the fold has dragged the corner in (along the radius, towards the fold line).
            dragged = sum(d * r for d, r in zip(sub(points[target], end), radius)) / length
            short = max(allowance, dragged) * angle / math.pi
            out.append([center[k] + (math.cos(angle) + short / length) * radius[k] + lift * self.normal[k]
                        for k in range(3)])
        return out

    def on_state(self, state):
        if self.rest is None:
            self.learn_grid(state)
        if self.start_s is None or state.sim_time < self.start_s:  # first, or after a ~reset
            self.start_s = state.sim_time
            self.released = False
        t = state.sim_time - self.start_s
        if self.loop and t > self.period:
            rospy.wait_for_service(self.reset_name, timeout=10.0)
            rospy.ServiceProxy(self.reset_name, Trigger)()
            self.start_s = None
            return
        end = t + FRAME_S
        if end <= START_S or self.released:
            return
        if end > START_S + CARRY_S + HOLD_S:
            for k in range(2):
                self.send(state.header.frame_id, k, Grasp.RELEASE, self.rest[self.held[k]])
            self.released = True
            rospy.loginfo("fold_demo_driver: let go at %.2f s", t)
            return
        points = [(p.x, p.y, p.z) for p in state.positions]
        for k, hand in enumerate(self.hands(end, points)):
            self.send(state.header.frame_id, k, Grasp.GRAB, hand)

    def send(self, frame_id, hand, action, point):
        message = Grasp()
        message.header.stamp = rospy.Time.now()
        message.header.frame_id = frame_id
        message.id = FIRST_GRASP_ID + hand
        message.action = action
        message.particle = self.held[hand]
        message.target.x, message.target.y, message.target.z = point
        message.stiffness = self.stiffness
        self.grasp.publish(message)


if __name__ == "__main__":
    rospy.init_node("fold_demo_driver")
    FoldDriver()
    rospy.spin()
