#!/usr/bin/python3
"""Faults around a running cloth_node: the ROS master restarted under it, SIGTERM, and SIGINT during long work.

Each test starts its own master (`rosmaster --core` on a free port) and its own cloth_node as processes it
can signal and restart; rostest's master is not used. Services and topics are reached with the
`rosservice` and `rostopic` tools pointed at that master. The CLOTH_NODE environment variable overrides
the node binary (to run these tests against another build). Run by test/ros/faults.test.
"""
import os
import re
import signal
import socket
import subprocess
import tempfile
import time
import unittest
import xmlrpc.client

import rostest

NODE = "/cloth_node"
CALLER = "/test_faults"
# Deadlines, wall time; each wait ends as soon as its condition holds.
APPEAR_S = 30.0  # a master, a registration, a message or a service answer
EXIT_S = 10.0    # a node told to stop is gone (its shutdown watchdog allows a frame 3 s)
TOOL_S = 30.0    # one rosservice / rostopic run
POLL_S = 0.1
# A cloth whose frames take long enough for a ~step to be running when the signal comes.
# sleep_speed 0: these steps must be long. The nodes here run the `hanging` scene, whose sheet at 64x64
# comes to rest and sleeps about 1.1 s of simulated time after its start; a step begun near frame 20
# then finished its 1,000-2,000 frames in under 2 s, before the signal came.
MID_GRID = ["_rows:=64", "_cols:=64", "_sleep_speed:=0"]
# One frame of this takes about 20 s here (a 512x512 rk4 frame is the uninterruptible one).
HUGE_FRAME = ["_rows:=512", "_cols:=512", "_integrator:=rk4", "_substeps:=20"]
# The first frame starts one timer tick (20 ms) after the services are registered: by this much later it
# is surely running, and it lasts seconds more.
INTO_THE_FRAME_S = 0.5


def free_port():
    with socket.socket() as probe:
        probe.bind(("localhost", 0))
        return probe.getsockname()[1]


def wait_for(condition, timeout_s):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(POLL_S)
    return condition()


def node_binary():
    if os.environ.get("CLOTH_NODE"):
        return os.environ["CLOTH_NODE"]
    found = subprocess.run(["catkin_find", "--first-only", "--libexec", "cloth_sim", "cloth_node"],
                           stdout=subprocess.PIPE, universal_newlines=True, check=True)
    return found.stdout.strip()


class Master:
    """A rosmaster on a fixed port, so a second one can take the first one's place."""

    def __init__(self, port):
        self.uri = "http://localhost:%d" % port
        self.log = tempfile.TemporaryFile()
        self.process = subprocess.Popen(["rosmaster", "--core", "-p", str(port)], stdout=self.log,
                                        stderr=subprocess.STDOUT)
        self.proxy = xmlrpc.client.ServerProxy(self.uri)
        if not wait_for(self.answers, APPEAR_S):
            self.stop()
            raise RuntimeError("rosmaster on %s did not answer within %.0f s" % (self.uri, APPEAR_S))

    def answers(self):
        try:
            return self.proxy.getPid(CALLER)[0] == 1
        except OSError:
            return False

    def knows_node(self):
        return self.proxy.lookupNode(CALLER, NODE)[0] == 1

    def registrations(self):
        """Every (kind, name) the master lists with the node as publisher, subscriber or service provider."""
        publishers, subscribers, services = self.proxy.getSystemState(CALLER)[2]
        return {(kind, name) for kind, entries in (("pub", publishers), ("sub", subscribers), ("srv", services))
                for name, nodes in entries if NODE in nodes}

    def serves(self, *names):
        registered = self.registrations()
        return all(("srv", NODE + "/" + name) in registered for name in names)

    def stop(self):
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(EXIT_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()


class Node:
    def __init__(self, master, arguments):
        self.master = master
        self.log = tempfile.NamedTemporaryFile(prefix="cloth_node_", suffix=".log")
        self.process = subprocess.Popen([node_binary(), "__name:=" + NODE[1:], "_scene:=hanging"] + arguments,
                                        stdout=self.log, stderr=subprocess.STDOUT, env=master_env(master))

    def output(self):
        with open(self.log.name, errors="replace") as text:
            return text.read()

    def alive(self):
        return self.process.poll() is None

    def stop(self, signal_number):
        """Sends the signal; the exit code, or None if the node is still there after EXIT_S."""
        self.process.send_signal(signal_number)
        try:
            return self.process.wait(EXIT_S)
        except subprocess.TimeoutExpired:
            return None

    def kill(self):
        if self.alive():
            self.process.kill()
            self.process.wait()


def master_env(master):
    env = dict(os.environ)
    env["ROS_MASTER_URI"] = master.uri
    return env


def call(master, service, value):
    """rosservice call against `master`; its YAML answer as text (or the failure)."""
    done = subprocess.run(["rosservice", "call", NODE + "/" + service, str(value)], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True, env=master_env(master),
                          timeout=TOOL_S)
    return done.stdout


def latest_frame(master):
    """The frame number of one ~state message received now, or None."""
    done = subprocess.run(["rostopic", "echo", "-n", "1", NODE + "/state/frame"], stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, universal_newlines=True, env=master_env(master),
                          timeout=TOOL_S)
    found = re.match(r"\s*(\d+)", done.stdout)
    return int(found.group(1)) if found else None


class Faults(unittest.TestCase):
    def setUp(self):
        self.port = free_port()
        self.masters = []
        self.nodes = []

    def tearDown(self):
        for node in self.nodes:
            node.kill()
        for master in self.masters:
            master.stop()

    def start_master(self):
        master = Master(self.port)
        self.masters.append(master)
        return master

    def start_node(self, master, arguments):
        node = Node(master, arguments)
        self.nodes.append(node)
        self.assertTrue(wait_for(lambda: not node.alive() or master.serves("pause", "step"), APPEAR_S),
                        "the node did not register its services:\n" + node.output())
        self.assertTrue(node.alive(), node.output())
        return node

    def expect_clean_exit(self, node, master, signal_number):
        start = time.monotonic()
        code = node.stop(signal_number)
        print("%s: exit code %s after %.1f s" % (signal_number.name, code, time.monotonic() - start))
        self.assertIsNotNone(code, "still running %.0f s after %s:\n%s" % (EXIT_S, signal_number.name, node.output()))
        self.assertEqual(code, 0, "%s: exit code %s\n%s" % (signal_number.name, code, node.output()))
        self.assertEqual(master.registrations(), set(), "left registered after " + signal_number.name)
        self.assertFalse(master.knows_node(), "the master still lists the node after " + signal_number.name)

    def test_after_a_master_restart_new_subscribers_and_service_calls_reach_the_node(self):
        first = self.start_master()
        node = self.start_node(first, ["_rows:=8", "_cols:=8"])
        first.stop()
        second = self.start_master()
        start = time.monotonic()
        self.assertTrue(wait_for(lambda: second.serves("pause", "step", "reset") and
                                 ("pub", NODE + "/state") in second.registrations(), APPEAR_S),
                        "the node never registered with the new master:\n" + node.output())
        print("registered with the new master %.1f s after it answered" % (time.monotonic() - start))
        frame = latest_frame(second)
        self.assertIsNotNone(frame, "a subscriber started after the restart got no ~state")
        answer = call(second, "pause", "true")
        self.assertIn("success: True", answer)
        self.assertIn("does not know this node", node.output(), "the restart was not logged")
        self.expect_clean_exit(node, second, signal.SIGTERM)

    def test_sigterm_shuts_down_cleanly_and_unregisters(self):
        master = self.start_master()
        node = self.start_node(master, ["_rows:=8", "_cols:=8"])
        self.expect_clean_exit(node, master, signal.SIGTERM)

    def test_an_absurdly_long_step_is_refused_and_sigint_stops_a_long_one(self):
        self.check_a_signal_during_a_long_step_answers_it(signal.SIGINT)

    def test_sigterm_during_a_long_step_answers_it_before_the_node_leaves(self):
        self.check_a_signal_during_a_long_step_answers_it(signal.SIGTERM)

    def check_a_signal_during_a_long_step_answers_it(self, signal_number):
        """The caller of a ~step in progress gets success=false with the reason (issue 18: it got a
        transport error, the node having shut its connections before answering)."""
        master = self.start_master()
        node = self.start_node(master, MID_GRID)
        self.assertIn("success: True", call(master, "pause", "true"))
        # Hours of work at this grid's cost per frame: refused, naming how many frames would fit.
        refusal = call(master, "step", 10000)
        self.assertIn("success: False", refusal)
        fitting = re.search(r"at most (\d+) frames", refusal)
        self.assertIsNotNone(fitting, refusal)
        paused_frame = latest_frame(master)
        self.assertIsNotNone(paused_frame)
        long_step = subprocess.Popen(["rosservice", "call", NODE + "/step", fitting.group(1)], stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, universal_newlines=True, env=master_env(master))
        try:
            # Paused, the frame advances only through the step: it is running once the frame moves.
            self.assertTrue(wait_for(lambda: (latest_frame(master) or 0) > paused_frame, APPEAR_S),
                            "the step did not start")
            self.assertIsNone(long_step.poll(), "the step ended before the signal: too short to prove anything")
            self.expect_clean_exit(node, master, signal_number)
            answer = long_step.communicate(timeout=TOOL_S)[0]
            print("the step's caller got: %s" % answer.strip())
            self.assertIn("success: False", answer)
            self.assertIn("the node is shutting down (%s)" % signal_number.name, answer)
        finally:
            if long_step.poll() is None:
                long_step.kill()
            long_step.wait()

    def test_sigint_during_a_frame_that_takes_long_ends_the_node_promptly(self):
        master = self.start_master()
        node = self.start_node(master, HUGE_FRAME)
        time.sleep(INTO_THE_FRAME_S)
        self.expect_clean_exit(node, master, signal.SIGINT)


if __name__ == "__main__":
    rostest.rosrun("cloth_sim", "faults", Faults)
