#!/usr/bin/python3
"""Issue 18 against live nodes (run by test/ros/second_pass.test); every wait is a condition with a deadline.

- ~save_state onto an existing FIFO is answered (refused: not a regular file) while the cloth keeps
  running; it blocked the node until something wrote to the FIFO.
- ~step answers with the frames it did when ~load_state puts the frame counter back in the middle of it
  ("stopped after 18446744073709548616 frames" before).
- A flood of ~grasp (GRAB 16 ids, RELEASE them, again and again) beside ~wind as fast as this process can
  publish, ending in RELEASE of all 16 ids: nothing is held afterwards (diagnostics "grasps held").
- A ~step called right after ~load_scene, with no frame's cost to estimate from, stops after its first frame
  when the rest would take over 30 s (it ran on for 60 s before).
- A scene reset by the recovery says which grasps it let go: a diagnostics ERROR naming the ids; and
  ~state counts on from frame 0, every frame once, its stamps rising (frames are counted from the reset).
"""
import os
import re
import shutil
import struct
import tempfile
import threading
import time
import unittest
import zlib

import rospy
import rostest
from cloth_sim.msg import ClothState, Grasp
from cloth_sim.srv import LoadScene, LoadState, SaveState, Step
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Vector3Stamped
from std_srvs.srv import SetBool

BUSY = "/cloth_busy"
SMALL = "/cloth_small"
DEADLINE_S = 30.0
MAX_STEP_FRAMES = 10000  # ClothNode::kMaxStepFrames
GRASP_IDS = range(16)    # Simulation::kMaxGrasps
FLOOD_ROUNDS = 40
FRAMES_AFTER_RESET = 20  # ~state messages read after the recovery's frame 0
HEADER_BYTES = 32        # doc/STATE_FILE.md
CHECKSUM_OFFSET = 24
SECTION_HEADER_BYTES = 12  # tag and length
STATE_PREFIX_BYTES = 24    # particle count, time, frame


def service(node, name, kind):
    rospy.wait_for_service(node + "/" + name, DEADLINE_S)
    return rospy.ServiceProxy(node + "/" + name, kind)


def wait_for(condition, timeout_s=DEADLINE_S):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and not rospy.is_shutdown():
        if condition():
            return True
        time.sleep(0.02)
    return condition()


class Latest:
    """The latest message of a topic."""

    def __init__(self, topic, kind):
        self.message = None
        self.subscriber = rospy.Subscriber(topic, kind, self.received, queue_size=10)

    def received(self, message):
        self.message = message


class Diagnostics:
    """The latest 'simulation' status of each node, as key -> value plus level and message."""

    def __init__(self):
        self.lock = threading.Lock()
        self.statuses = {}
        self.history = []
        self.subscriber = rospy.Subscriber("/diagnostics", DiagnosticArray, self.received, queue_size=50)

    def received(self, array):
        with self.lock:
            for status in array.status:
                entry = {"level": status.level, "message": status.message,
                         "values": {kv.key: kv.value for kv in status.values}}
                self.statuses[status.name] = entry
                self.history.append((status.name, entry))

    def of(self, node):
        with self.lock:
            for name, entry in self.statuses.items():
                if name.startswith(node[1:] + ":"):
                    return entry
        return None

    def seen(self, node, predicate):
        with self.lock:
            return any(name.startswith(node[1:] + ":") and predicate(entry) for name, entry in self.history)


def sections(data):
    """The state file's sections by tag (doc/STATE_FILE.md)."""
    found, at = {}, HEADER_BYTES
    while at < len(data):
        tag, length = data[at:at + 4].decode(), struct.unpack_from("=Q", data, at + 4)[0]
        found[tag] = data[at + SECTION_HEADER_BYTES:at + SECTION_HEADER_BYTES + length]
        at += SECTION_HEADER_BYTES + length
    return found


def grasps_in_a_save(node, folder):
    """How many grasps the node holds, from a ~save_state (its INPT section), or None if it did not save."""
    path = os.path.join(folder, "held.clothstate")
    if os.path.exists(path):
        os.remove(path)
    if not service(node, "save_state", SaveState)(path).success:
        return None
    with open(path, "rb") as f:
        inputs = sections(f.read())["INPT"]
    pins = struct.unpack_from("=Q", inputs, 24)[0]
    return struct.unpack_from("=Q", inputs, 24 + 8 + 4 * pins + 48 * pins)[0]


def step_in_background(node, frames):
    """Calls ~step on a thread; the answer (or the exception) lands in the returned dict."""
    answer = {}

    def run():
        try:
            answer["response"] = service(node, "step", Step)(frames)
        except Exception as error:  # the test reports it
            answer["error"] = error

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return answer, thread


class SecondPass(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_second_pass")
        cls.diagnostics = Diagnostics()

    def setUp(self):
        self.folder = tempfile.mkdtemp(prefix="cloth_second_pass_")

    def tearDown(self):
        shutil.rmtree(self.folder, ignore_errors=True)

    def test_save_onto_a_fifo_is_refused_while_the_cloth_runs_on(self):
        fifo = os.path.join(self.folder, "state.clothstate")
        os.mkfifo(fifo)
        state = Latest(SMALL + "/state", ClothState)
        self.assertTrue(wait_for(lambda: state.message is not None), "no ~state")
        answer = {}
        thread = threading.Thread(target=lambda: answer.update(r=service(SMALL, "save_state", SaveState)(fifo)),
                                  daemon=True)
        thread.start()
        thread.join(DEADLINE_S)
        if thread.is_alive():
            # Blocked in open(): a writer wakes it, so the node is left usable for the other tests.
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
            self.fail("~save_state onto a FIFO was not answered within %.0f s" % DEADLINE_S)
        self.assertFalse(answer["r"].success)
        self.assertIn("not a regular file", answer["r"].message)
        frame = state.message.frame
        self.assertTrue(wait_for(lambda: state.message.frame > frame), "the cloth stopped after the save")

    def test_a_step_cut_short_by_load_state_answers_the_frames_it_did(self):
        pause = service(BUSY, "pause", SetBool)
        self.assertTrue(pause(True).success)
        path = os.path.join(self.folder, "early.clothstate")
        saved = service(BUSY, "save_state", SaveState)(path)
        self.assertTrue(saved.success, saved.message)
        state = Latest(BUSY + "/state", ClothState)
        self.assertTrue(wait_for(lambda: state.message is not None), "no ~state")
        # The long step begins after the saved frame (as the issue's: saved at 100, step begun at 3100), so
        # a difference of frame numbers taken after the load would be negative.
        ahead = service(BUSY, "step", Step)(20)
        self.assertTrue(ahead.success, ahead.message)
        # A step as long as one call may take (the node names the most that fit at its cost per frame).
        frames = MAX_STEP_FRAMES
        refusal = service(BUSY, "step", Step)(frames)
        if not refusal.success:
            fitting = re.search(r"at most (\d+) frames", refusal.message)
            self.assertIsNotNone(fitting, refusal.message)
            frames = int(fitting.group(1))
        saved_frame = state.message.frame
        answer, thread = step_in_background(BUSY, frames)
        self.assertTrue(wait_for(lambda: state.message.frame > saved_frame + 5), "the step did not start")
        self.assertNotIn("response", answer, "the step ended before ~load_state: too short to prove anything")
        loaded = service(BUSY, "load_state", LoadState)(path)
        self.assertTrue(loaded.success, loaded.message)
        thread.join(DEADLINE_S)
        self.assertIn("response", answer, answer.get("error", "no answer"))
        response = answer["response"]
        self.assertFalse(response.success)
        done = re.search(r"stopped after (\d+) frames", response.message)
        self.assertIsNotNone(done, response.message)
        self.assertGreater(int(done.group(1)), 0, response.message)
        self.assertLess(int(done.group(1)), frames, response.message)
        self.assertIn("~load_state", response.message)
        self.assertTrue(pause(False).success)

    def test_a_step_right_after_load_scene_stops_after_its_first_frame_if_the_rest_would_take_too_long(self):
        heavy = os.path.join(self.folder, "heavy.yaml")
        with open(heavy, "w") as f:  # 8x8 at 2000 RK4 substeps: tens of ms a frame, 10000 frames far over 30 s
            f.write("rows: 8\ncols: 8\nintegrator: rk4\nsubsteps: 2000\nsleep_speed: 0.0\n")
        light = os.path.join(self.folder, "light.yaml")
        with open(light, "w") as f:  # back to an 8x8 hanging sheet for the tests after this one
            f.write("rows: 8\ncols: 8\n")
        pause = service(SMALL, "pause", SetBool)
        self.assertTrue(pause(True).success)
        try:
            loaded = service(SMALL, "load_scene", LoadScene)(heavy)
            self.assertTrue(loaded.success, loaded.message)
            started = time.monotonic()
            answer = service(SMALL, "step", Step)(MAX_STEP_FRAMES)
            print("the step after load_scene answered in %.1f s: %s" % (time.monotonic() - started, answer.message))
            self.assertFalse(answer.success, answer.message)
            self.assertIn("stopped after 1 frames", answer.message)
            self.assertIn("would take about", answer.message)
            self.assertIsNotNone(re.search(r"at most (\d+) frames", answer.message), answer.message)
            # The next call has the first frame's cost to go by and is refused outright.
            refusal = service(SMALL, "step", Step)(MAX_STEP_FRAMES)
            self.assertFalse(refusal.success)
            self.assertNotIn("stopped after", refusal.message)
            self.assertIn("would take about", refusal.message)
        finally:
            restored = service(SMALL, "load_scene", LoadScene)(light)
            self.assertTrue(pause(False).success)
        self.assertTrue(restored.success, restored.message)

    def test_a_grasp_flood_ending_in_release_leaves_nothing_held(self):
        state = Latest(BUSY + "/state", ClothState)
        grasp = rospy.Publisher(BUSY + "/grasp", Grasp, queue_size=100000)
        wind = rospy.Publisher(BUSY + "/wind", Vector3Stamped, queue_size=100000)
        self.assertTrue(wait_for(lambda: grasp.get_num_connections() > 0 and wind.get_num_connections() > 0))
        self.assertTrue(wait_for(lambda: state.message is not None), "no ~state")
        stop = threading.Event()

        def blow():
            gust = Vector3Stamped()
            while not stop.is_set():
                gust.vector.x = 1.0 + (time.monotonic() % 1.0)
                wind.publish(gust)

        blower = threading.Thread(target=blow, daemon=True)
        blower.start()
        try:
            for _ in range(FLOOD_ROUNDS):
                for action in (Grasp.GRAB, Grasp.RELEASE):
                    for grasp_id in GRASP_IDS:
                        command = Grasp(id=grasp_id, action=action, particle=-1)
                        command.target.x, command.target.z = -0.5 + grasp_id / 16.0, 1.5
                        grasp.publish(command)
        finally:
            stop.set()
            blower.join()
        # The last command of every id was a RELEASE: once the node has taken them all, nothing is held,
        # in the node's own state (a save's inputs) and in its diagnostics.
        self.assertTrue(wait_for(lambda: grasps_in_a_save(BUSY, self.folder) == 0),
                        "%s grasps still held after the flood" % grasps_in_a_save(BUSY, self.folder))
        self.assertTrue(wait_for(lambda: (self.diagnostics.of(BUSY) or {}).get("values", {}).get("grasps held") == ""),
                        "still held after the flood: %s" % (self.diagnostics.of(BUSY) or {}).get("values", {}).get(
                            "grasps held"))
        frame = state.message.frame
        self.assertTrue(wait_for(lambda: state.message.frame > frame), "the node stopped after the flood")

    def test_a_reset_by_the_recovery_names_the_grasps_it_released(self):
        hand = rospy.Publisher(SMALL + "/grasp", Grasp, queue_size=10)
        self.assertTrue(wait_for(lambda: hand.get_num_connections() > 0))
        command = Grasp(id=77, action=Grasp.GRAB, particle=10)
        command.target.x, command.target.z = -0.2, 1.4
        hand.publish(command)
        self.assertTrue(wait_for(lambda: (self.diagnostics.of(SMALL) or {}).get("values", {}).get("grasps held") == "77"),
                        "the grasp was not taken")
        # A state beyond saving, held by the grasp: every particle flying at 1e5 m/s leaves the guard's
        # 1000 m box within a frame however it is computed, so the recovery resets the scene.
        path = os.path.join(self.folder, "flying.clothstate")
        pause = service(SMALL, "pause", SetBool)
        self.assertTrue(pause(True).success)
        saved = service(SMALL, "save_state", SaveState)(path)
        self.assertTrue(saved.success, saved.message)
        with open(path, "rb") as f:
            data = bytearray(f.read())
        options_length = struct.unpack_from("=Q", data, HEADER_BYTES + 4)[0]
        state_at = HEADER_BYTES + SECTION_HEADER_BYTES + options_length + SECTION_HEADER_BYTES
        particles = struct.unpack_from("=Q", data, state_at)[0]
        velocities_at = state_at + STATE_PREFIX_BYTES + 24 * particles
        struct.pack_into("=%dd" % (3 * particles), data, velocities_at, *([1e5] * (3 * particles)))
        data[CHECKSUM_OFFSET:CHECKSUM_OFFSET + 4] = struct.pack("=I", zlib.crc32(bytes(data[HEADER_BYTES:])) & 0xffffffff)
        with open(path, "wb") as f:
            f.write(bytes(data))
        loaded = service(SMALL, "load_state", LoadState)(path)
        self.assertTrue(loaded.success, loaded.message)
        lock = threading.Lock()
        states = []

        def on_state(message):
            with lock:
                states.append((message.frame, message.header.stamp))

        subscriber = rospy.Subscriber(SMALL + "/state", ClothState, on_state, queue_size=1000)
        self.assertTrue(wait_for(lambda: subscriber.get_num_connections() > 0), "no connection to ~state")

        def after_reset():
            with lock:
                zeros = [k for k, (frame, _) in enumerate(states) if frame == 0]
                return states[zeros[-1]:] if zeros else []

        self.assertTrue(pause(False).success)
        self.assertTrue(wait_for(lambda: self.diagnostics.seen(
            SMALL, lambda entry: entry["level"] == 2 and "released grasp ids 77" in entry["message"])),
            "no diagnostics ERROR naming grasp 77; last: %s" % self.diagnostics.of(SMALL))
        self.assertTrue(wait_for(lambda: len(after_reset()) > FRAMES_AFTER_RESET),
                        "no frame 0 and %d after it on ~state: %s" % (FRAMES_AFTER_RESET, states[-5:]))
        subscriber.unregister()
        run = after_reset()[:FRAMES_AFTER_RESET + 1]
        frames = [frame for frame, _ in run]
        self.assertEqual(frames, list(range(len(run))), "frames after the reset missing or repeated: %s" % frames)
        stamps = [stamp.to_sec() for _, stamp in run]
        self.assertTrue(all(later > earlier for earlier, later in zip(stamps, stamps[1:])),
                        "stamps after the reset not rising: %s" % stamps)


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "second_pass", SecondPass)
