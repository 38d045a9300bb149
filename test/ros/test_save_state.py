#!/usr/bin/python3
"""~save_state and ~load_state against live nodes under /use_sim_time (run by test/ros/save_state.test).

Save, kill the node, start a new one, load, continue: the new node publishes the bits the uninterrupted
run published, frame by frame. And every way a save or load can fail answers success=false with the
reason, quoting no file content, and leaves the running cloth untouched.
"""
import os
import shutil
import signal
import struct
import subprocess
import tempfile
import threading
import time
import unittest
import xmlrpc.client
import zlib

import rosgraph
import roslib.packages
import rospy
import rostest
from cloth_sim.msg import ClothState, Grasp
from cloth_sim.srv import LoadState, SaveState
from dynamic_reconfigure.msg import Config, DoubleParameter
from dynamic_reconfigure.srv import Reconfigure
from geometry_msgs.msg import Point
from rosgraph_msgs.msg import Clock

FRAME_NS = 20000000          # one frame at the nodes' 50 Hz
T0_NS = 100 * 1000000000     # the first clock: each node anchors frame 0 on it
DEADLINE_S = 20.0            # per wait, wall clock; nothing here sleeps a fixed time to "settle"
FRAMES_AFTER_SAVE = 30
CORNER = 0                   # top_left, pinned in the hanging scene
HEADER_BYTES = 32            # doc/STATE_FILE.md
VERSION_OFFSET = 12
CHECKSUM_OFFSET = 24


def stamp(ns):
    return rospy.Time(ns // 1000000000, ns % 1000000000)


def bits(state):
    """Positions and velocities as exact bytes (== on floats would equate -0 and 0)."""
    values = [c for p in state.positions for c in (p.x, p.y, p.z)]
    values += [c for v in state.velocities for c in (v.x, v.y, v.z)]
    return struct.pack("<%dd" % len(values), *values)


def position(state, index):
    p = state.positions[index]
    return (p.x, p.y, p.z)


class Monitor:
    """Every ~state of one node, in arrival order."""

    def __init__(self, node):
        self.states = []
        self.lock = threading.Lock()
        self.subscriber = rospy.Subscriber(node + "/state", ClothState, self.callback, queue_size=100)

    def callback(self, state):
        with self.lock:
            self.states.append(state)

    def connected(self):
        """Waits until the node publishes to us: a tick's state before that would be lost (it publishes
        ~state only to subscribers), and under a held clock no other tick comes."""
        end = time.monotonic() + DEADLINE_S
        while self.subscriber.get_num_connections() < 1 and time.monotonic() < end:
            time.sleep(0.01)
        return self.subscriber.get_num_connections() >= 1

    def wait_for(self, condition, deadline_s=DEADLINE_S):
        """The first state (oldest first) meeting condition, or None after the deadline."""
        end = time.monotonic() + deadline_s
        while time.monotonic() < end and not rospy.is_shutdown():
            with self.lock:
                for state in self.states:
                    if condition(state):
                        return state
            time.sleep(0.005)
        return None


class Clock_:
    def __init__(self):
        self.publisher = rospy.Publisher("/clock", Clock, queue_size=10)
        self.now_ns = T0_NS

    def publish(self):
        self.publisher.publish(Clock(clock=stamp(self.now_ns)))

    def settle(self, monitor, condition):
        """Repeats the current clock until the node publishes a state meeting condition (a node anchors on
        the first clock it hears, and clocks sent before it subscribed are lost)."""
        end = time.monotonic() + DEADLINE_S
        while time.monotonic() < end:
            self.publish()
            state = monitor.wait_for(condition, 0.2)
            if state is not None:
                return state
        return None

    def tick(self, monitor, frame):
        """One frame later; the node's state for that frame."""
        self.now_ns += FRAME_NS
        self.publish()
        return monitor.wait_for(lambda s: s.frame >= frame)


def save(node, path):
    rospy.wait_for_service(node + "/save_state", DEADLINE_S)
    return rospy.ServiceProxy(node + "/save_state", SaveState)(path)


def load(node, path):
    rospy.wait_for_service(node + "/load_state", DEADLINE_S)
    return rospy.ServiceProxy(node + "/load_state", LoadState)(path)


def node_pid(node):
    master = rosgraph.Master("/test_save_state")
    return xmlrpc.client.ServerProxy(master.lookupNode(node)).getPid("/test_save_state")[2]


def rewrite(path, change):
    """Applies change to the file's bytes and fixes the header's CRC-32, so the check behind it is reached."""
    with open(path, "rb") as f:
        data = bytearray(f.read())
    change(data)
    data[CHECKSUM_OFFSET:CHECKSUM_OFFSET + 4] = struct.pack("=I", zlib.crc32(bytes(data[HEADER_BYTES:])) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(bytes(data))


class SaveAndLoad(unittest.TestCase):
    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="cloth_save_state_")

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_a_failed_save_or_load_answers_why_and_leaves_the_cloth_untouched(self):
        before = os.path.join(self.folder, "before.clothstate")
        response = save("/cloth_f", before)
        self.assertTrue(response.success, response.message)

        # Saves that cannot be written.
        for path, reason in [(os.path.join(self.folder, "missing", "x.clothstate"), "No such file"),
                             (self.folder, "is a directory"), ("", "no path")]:
            response = save("/cloth_f", path)
            self.assertFalse(response.success, path)
            self.assertIn(reason, response.message)
        secret = "SECRET-CONTENT-" * 20
        other = os.path.join(self.folder, "notes.txt")
        with open(other, "w") as f:
            f.write(secret)
        response = save("/cloth_f", other)
        self.assertFalse(response.success)
        self.assertIn("not replaced", response.message)
        with open(other) as f:
            self.assertEqual(f.read(), secret)

        # Loads that must be refused.
        other_grid = os.path.join(self.folder, "other_grid.clothstate")
        self.assertTrue(save("/cloth_o", other_grid).success)
        with open(before, "rb") as f:
            good = f.read()
        truncated = os.path.join(self.folder, "truncated.clothstate")
        with open(truncated, "wb") as f:
            f.write(good[:len(good) // 2])
        corrupted = os.path.join(self.folder, "corrupted.clothstate")
        with open(corrupted, "wb") as f:
            f.write(good[:-9] + bytes([good[-9] ^ 0x40]) + good[-8:])
        newer = os.path.join(self.folder, "newer.clothstate")
        with open(newer, "wb") as f:
            f.write(good)
        rewrite(newer, lambda data: data.__setitem__(slice(VERSION_OFFSET, VERSION_OFFSET + 4), struct.pack("=I", 99)))
        for path, reasons in [(other_grid, ["12x12", "10x10"]), (truncated, ["truncated"]), (corrupted, ["CRC-32"]),
                              (newer, ["version 99 is not supported"]), (other, ["not a cloth_sim state file"]),
                              (os.path.join(self.folder, "absent.clothstate"), ["no such file"]),
                              (self.folder, ["not a regular file"]), ("", ["no path"])]:
            response = load("/cloth_f", path)
            self.assertFalse(response.success, path)
            for reason in reasons:
                self.assertIn(reason, response.message)
            self.assertIn("untouched", response.message)
            self.assertNotIn("SECRET", response.message)

        after = os.path.join(self.folder, "after.clothstate")
        self.assertTrue(save("/cloth_f", after).success)
        with open(after, "rb") as f:
            self.assertEqual(f.read(), good, "a refused load or save changed the running cloth")
        self.assertEqual([n for n in os.listdir(self.folder) if ".tmp-" in n], [], "a temporary file was left")

    def test_b_save_kill_restart_load_continues_with_the_same_bits(self):
        clock = Clock_()
        a = Monitor("/cloth_a")
        self.assertTrue(a.connected(), "node A does not publish ~state")
        first = clock.settle(a, lambda s: s.header.stamp == stamp(T0_NS))
        self.assertIsNotNone(first, "node A did not answer the first clock")
        self.assertEqual(first.frame, 0)
        frame = 0

        def advance(count):
            nonlocal frame
            state = None
            for _ in range(count):
                frame += 1
                state = clock.tick(a, frame)
                self.assertIsNotNone(state, "no state for frame %d" % frame)
                self.assertEqual(state.frame, frame, "one tick advanced more than one frame")
            return state

        advance(5)
        # Tuning and wind through dynamic_reconfigure: a service, so in force when it answers.
        rospy.wait_for_service("/cloth_a/tuning/set_parameters", DEADLINE_S)
        tune = rospy.ServiceProxy("/cloth_a/tuning/set_parameters", Reconfigure)
        tune(Config(doubles=[DoubleParameter("structural_stiffness", 1500.0), DoubleParameter("air_damping", 0.01),
                             DoubleParameter("wind_x", 2.0), DoubleParameter("wind_y", -1.0)]))

        # Grasps: a free particle held, the pinned corner grabbed; both on one connection, in order, so
        # once the corner moves off its hook both are in force.
        grasps = rospy.Publisher("/cloth_a/grasp", Grasp, queue_size=10)
        end = time.monotonic() + DEADLINE_S
        while grasps.get_num_connections() < 1 and time.monotonic() < end:
            time.sleep(0.01)
        self.assertGreaterEqual(grasps.get_num_connections(), 1, "node A does not hear ~grasp")
        hooked = position(advance(1), CORNER)
        grasps.publish(Grasp(id=3, action=Grasp.GRAB, particle=55, target=Point(0.1, 0.3, 1.0)))
        grasps.publish(Grasp(id=7, action=Grasp.GRAB, particle=CORNER,
                             target=Point(hooked[0] - 0.2, hooked[1] + 0.1, hooked[2] + 0.1)))
        for _ in range(50):
            if position(advance(1), CORNER) != hooked:
                break
        self.assertNotEqual(position(a.states[-1], CORNER), hooked, "the grabbed corner never left its hook")
        advance(5)
        # Let go: the corner hangs on a new hook where it was let go, and stays there.
        grasps.publish(Grasp(id=7, action=Grasp.RELEASE))
        previous = position(a.states[-1], CORNER)
        for _ in range(50):
            current = position(advance(1), CORNER)
            if current == previous:
                break
            previous = current
        self.assertEqual(position(a.states[-1], CORNER), previous, "the let-go corner was never hooked again")
        self.assertNotEqual(previous, hooked, "the corner was hooked again where it started: proves nothing")
        advance(3)

        path = os.path.join(self.folder, "a.clothstate")
        response = save("/cloth_a", path)
        self.assertTrue(response.success, response.message)
        saved_frame = frame
        at_save = a.states[-1]
        self.assertEqual(at_save.frame, saved_frame)

        # The uninterrupted run.
        uninterrupted = {saved_frame: at_save}
        for _ in range(FRAMES_AFTER_SAVE):
            state = advance(1)
            uninterrupted[state.frame] = state
        os.kill(node_pid("/cloth_a"), signal.SIGKILL)

        # A new node, started with only the grid's parameters: the rest comes from the file.
        binary = roslib.packages.find_node("cloth_sim", "cloth_node")[0]
        b_process = subprocess.Popen([binary, "__name:=cloth_b", "_scene:=hanging", "_rows:=10", "_cols:=10"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            b = Monitor("/cloth_b")
            self.assertTrue(b.connected(), "node B does not publish ~state")
            self.assertIsNotNone(clock.settle(b, lambda s: s.frame == 0), "node B did not start")
            response = load("/cloth_b", path)
            self.assertTrue(response.success, response.message)
            loaded = b.wait_for(lambda s: s.frame == saved_frame)
            self.assertIsNotNone(loaded, "node B published no state at the loaded frame")
            self.assertTrue(bits(loaded) == bits(at_save), "the loaded state differs from the saved one")
            for k in range(saved_frame + 1, saved_frame + FRAMES_AFTER_SAVE + 1):
                clock.now_ns += FRAME_NS
                clock.publish()
                state = b.wait_for(lambda s, k=k: s.frame >= k)
                self.assertIsNotNone(state, "node B published no state for frame %d" % k)
                self.assertEqual(state.frame, k, "one tick advanced node B more than one frame")
                self.assertEqual(state.sim_time, uninterrupted[k].sim_time)
                self.assertTrue(bits(state) == bits(uninterrupted[k]), "the runs differ at frame %d" % k)
            self.assertTrue(bits(at_save) != bits(uninterrupted[saved_frame + FRAMES_AFTER_SAVE]),
                                "the cloth did not move after the save: the comparison would prove nothing")
            self.assertIsNone(b_process.poll(), "node B died")
        finally:
            b_process.send_signal(signal.SIGINT)
            try:
                b_process.wait(timeout=DEADLINE_S)
            except subprocess.TimeoutExpired:
                b_process.kill()


if __name__ == "__main__":
    rospy.init_node("test_save_state")
    rostest.rosrun("cloth_sim", "save_state", SaveAndLoad)
