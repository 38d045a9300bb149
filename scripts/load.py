#!/usr/bin/python3
"""Floods cloth_node's ~wind and ~grasp and measures what the node keeps up (issue 9, "Load").

`make load` runs it as a standalone program: it starts its own ROS master on a free port and a cloth_node
on the hanging scene at 64x64, floods ~wind at 10 kHz and ~grasp at 1 kHz for 30 s from two processes,
and reports, for the flood's window:
  - the rates it sent at (what the connection took: publishing is synchronous, so a node that reads too
    slowly slows the sender down instead of hiding drops in the sender),
  - what the node received and dropped on each input (its own bus statistics: subscriber queues are
    bounded, so a flood must show up as drops, not as memory),
  - the ~state and ~mesh rates received and the frames advanced per second,
  - percentiles of the frame period (from the ~state stamps: a tick's last frame carries the tick's time,
    the frames it caught up on before it their own frame times, so a late tick shows as one long period),
  - the node's resident memory (VmRSS from /proc) before, after and at its peak.
--attach measures a node already running under ROS_MASTER_URI instead (test/ros/test_load.py does).
"""
import argparse
import json
import math
import multiprocessing
import os
import re
import signal
import socket
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import time
import warnings
import xmlrpc.client

CALLER = "/cloth_load"
READY_S = 30.0          # for the master, the node and the connections to appear
WARMUP_S = 2.0          # the node runs this long, connected, before the baseline memory is read
RSS_SAMPLE_S = 0.5
NODE_EXIT_S = 10.0
KIB_PER_MIB = 1024.0
# The grasps: four hands on the bottom row of the hanging scene's cloth (1 m wide, bottom edge near
# z = 0.5 m), swaying 5 cm along y every 2 s; every 100th round they let go and grab again.
GRASP_HANDS = 4
GRASP_X_M = (-0.5, -0.17, 0.17, 0.5)
GRASP_Z_M = 0.55
SWAY_M = 0.05
SWAY_PERIOD_S = 2.0
REGRAB_ROUNDS = 100
# The wind: 2 m/s along y, varying by 1 m/s so that no two consecutive messages are alike.
WIND_M_PER_S = 2.0
WIND_VARIATION_M_PER_S = 1.0
# The grid sides cloth_node accepts (core::OptionLimits::kMinGridSide, kMaxGridSide).
MIN_GRID_SIDE = 2
MAX_GRID_SIDE = 512
# A node that refuses its parameters says why in one ROS_FATAL line and exits; without one, this many of
# its last output lines are shown instead.
NODE_LOG_TAIL_LINES = 5
# The shortest flood load.py accepts: ~state at the node's 50 Hz gives some 50 frame periods a second, and the
# memory is sampled every RSS_SAMPLE_S; a shorter one reports percentiles of next to nothing.
MIN_SECONDS = 1.0
# rosconsole colours its FATAL and ERROR lines with terminal escapes: stripped from the lines quoted.
ANSI_ESCAPE = re.compile(r"\x1b\[[0-9;]*[A-Za-z]|\x1b\][^\x07]*\x07")


def master_proxy():
    import rosgraph
    return xmlrpc.client.ServerProxy(rosgraph.get_master_uri())


def wait_for(condition, timeout_s, period_s=0.05):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(period_s)
    return condition()


class NodeExited(RuntimeError):
    """A cloth_node this program started has exited; the message says so, with its FATAL line."""


def node_exit_message(process, log_path, when):
    """"cloth_node exited (code N) WHEN: <its FATAL line>" (or its last lines), from its output in log_path."""
    try:
        with open(log_path, errors="replace") as log:
            lines = [ANSI_ESCAPE.sub("", line).strip() for line in log]
    except OSError:
        lines = []
    lines = [line for line in lines if line]
    shown = [line for line in lines if "FATAL" in line] or lines[-NODE_LOG_TAIL_LINES:]
    return "cloth_node exited (code %s) %s: %s" % (process.returncode, when,
                                                   " | ".join(shown) if shown else "it printed nothing")


def advertises(proxy, caller, topic):
    """Whether some node publishes `topic` according to the master behind `proxy`."""
    _, _, (publishers, _, _) = proxy.getSystemState(caller)
    return any(name == topic and nodes for name, nodes in publishers)


def start_node(binary, parameters, log_path, proxy, caller, ready_s, name="/cloth_node"):
    """A cloth_node with `parameters` (["_scene:=flag", ...]), its output in log_path; returned once it
    advertises ~state. It registers with the master before it reads its parameters, so being registered
    says nothing: ~state is advertised only after the scene was built. NodeExited, with its FATAL line, if
    it exits first (a parameter or scene it refused)."""
    with open(log_path, "w") as log:
        node = subprocess.Popen([binary, "__name:=" + name.lstrip("/")] + parameters, stdout=log,
                                stderr=subprocess.STDOUT)
    if not wait_for(lambda: node.poll() is not None or advertises(proxy, caller, name + "/state"), ready_s):
        node.kill()
        node.wait()
        raise RuntimeError("cloth_node did not advertise %s/state within %.0f s" % (name, ready_s))
    if node.poll() is not None:
        raise NodeExited(node_exit_message(node, log_path, "before it started"))
    return node


def node_api(node):
    code, message, uri = master_proxy().lookupNode(CALLER, node)
    if code != 1:
        raise RuntimeError("the master does not know %s: %s" % (node, message))
    return xmlrpc.client.ServerProxy(uri)


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as status:
        for line in status:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise RuntimeError("no VmRSS for process %d" % pid)


def cpu_s(pid):
    """CPU time the process has used so far (user + system), s."""
    with open("/proc/%d/stat" % pid) as stat:
        fields = stat.read().rsplit(")", 1)[1].split()  # after the command name, which may hold spaces
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime


def input_stats(node, topics):
    """{topic: (messages received, messages dropped)} from the node's getBusStats: roscpp answers
    [publications, subscriptions] (without the usual status code), each subscription as
    [topic, [[connection id, bytes, messages, drops, 0], ...]]."""
    answer = node_api(node).getBusStats(CALLER)
    if len(answer) == 3 and answer[0] == 1:  # the slave API's usual [code, message, value]
        answer = answer[2]
    totals = {}
    for topic, connections in answer[1]:
        if topic in topics:
            received = sum(int(c[2]) for c in connections if len(c) > 3)
            dropped = sum(int(c[3]) for c in connections if len(c) > 3)
            totals[topic] = (received, dropped)
    return totals


# ---- the two flooders, each a process of its own (rospy's publishing holds the GIL) ------------------

def wind_message(index, stamp):
    from geometry_msgs.msg import Vector3Stamped
    wind = Vector3Stamped()
    wind.header.stamp = stamp
    wind.vector.y = WIND_M_PER_S + WIND_VARIATION_M_PER_S * math.sin(index * 0.01)
    return wind


def grasp_message(index, stamp):
    from cloth_sim.msg import Grasp
    grasp = Grasp()
    grasp.header.stamp = stamp
    hand = index % GRASP_HANDS
    grasp.id = hand
    regrab = (index // GRASP_HANDS) % REGRAB_ROUNDS == REGRAB_ROUNDS - 1
    grasp.action = Grasp.RELEASE if regrab else Grasp.GRAB
    grasp.particle = -1
    grasp.target.x = GRASP_X_M[hand]
    grasp.target.y = SWAY_M * math.sin(2.0 * math.pi * time.monotonic() / SWAY_PERIOD_S)
    grasp.target.z = GRASP_Z_M
    return grasp


def flood(topic, kind_name, rate_hz, seconds, ready, go, sent, measured):
    """Publishes at rate_hz for `seconds` once `go` is set; puts the rate sent into `sent`, and keeps its
    connection until `measured` is set (the node's statistics of a connection go with it)."""
    import rospy
    from cloth_sim.msg import Grasp
    from geometry_msgs.msg import Vector3Stamped
    kind, make = {"wind": (Vector3Stamped, wind_message), "grasp": (Grasp, grasp_message)}[kind_name]
    # Not this program's arguments: a __name:= among them (rostest passes one) would name every process alike.
    rospy.init_node("cloth_load_" + kind_name, argv=[], anonymous=True, disable_signals=True)
    with warnings.catch_warnings():  # rospy warns that queue_size=None publishes synchronously: meant
        warnings.simplefilter("ignore")
        publisher = rospy.Publisher(topic, kind, queue_size=None)
    if not wait_for(lambda: publisher.get_num_connections() > 0, READY_S):
        sent.put((kind_name, -1))
        return
    ready.set()
    go.wait()
    start = time.monotonic()
    count = 0
    stamp = rospy.Time.now()
    while True:
        elapsed = time.monotonic() - start
        if elapsed >= seconds:
            break
        due = int(elapsed * rate_hz)
        if count >= due:
            time.sleep(min(0.001, (count + 1) / rate_hz - elapsed))
            continue
        for _ in range(due - count):
            publisher.publish(make(count, stamp))
            count += 1
    sent.put((kind_name, count / (time.monotonic() - start)))
    measured.wait(READY_S)
    rospy.signal_shutdown("flood done")


# ---- what the node sends back ---------------------------------------------------------------------

class Receiver:
    """Receipt times, header stamps and frame numbers of ~state, and stamps of ~mesh, without
    deserialising the arrays (a 64x64 state is 8192 vectors)."""

    def __init__(self, node):
        import rospy
        self.lock = threading.Lock()
        self.states = []  # (receipt monotonic s, stamp s, frame)
        self.meshes = []  # (receipt monotonic s, stamp s)
        self.subscribers = [rospy.Subscriber(node + "/state", rospy.AnyMsg, self.on_state, queue_size=100),
                            rospy.Subscriber(node + "/mesh", rospy.AnyMsg, self.on_mesh, queue_size=100)]

    @staticmethod
    def stamp_and_end_of_header(buffer):
        _, secs, nsecs, frame_id_length = struct.unpack_from("<IIII", buffer, 0)
        return secs + nsecs * 1e-9, 16 + frame_id_length

    def on_state(self, message):
        buffer = message._buff
        stamp, offset = self.stamp_and_end_of_header(buffer)
        offset += 8  # rows, cols
        for _ in range(2):  # positions, velocities: a length, then 3 float64 each
            (count,) = struct.unpack_from("<I", buffer, offset)
            offset += 4 + 24 * count
        offset += 8  # sim_time
        (frame,) = struct.unpack_from("<Q", buffer, offset)
        with self.lock:
            self.states.append((time.monotonic(), stamp, frame))

    def on_mesh(self, message):
        stamp, _ = self.stamp_and_end_of_header(message._buff)
        with self.lock:
            self.meshes.append((time.monotonic(), stamp))

    def window(self, start, end):
        with self.lock:
            return ([s for s in self.states if start <= s[0] <= end], [m for m in self.meshes if start <= m[0] <= end])


def percentile(sorted_values, fraction):
    if not sorted_values:
        return float("nan")
    index = min(len(sorted_values) - 1, max(0, int(math.ceil(fraction * len(sorted_values))) - 1))
    return sorted_values[index]


def rate(samples):
    """Messages per second between the first and the last of `samples` (receipt times first)."""
    if len(samples) < 2:
        return 0.0
    return (len(samples) - 1) / (samples[-1][0] - samples[0][0])


def measure(node="/cloth_node", seconds=30.0, wind_hz=10000.0, grasp_hz=1000.0):
    """Floods `node` (running under ROS_MASTER_URI) and returns the figures as a dict."""
    import rospy
    context = multiprocessing.get_context("fork")  # before this process becomes a ROS node
    go = context.Event()
    measured = context.Event()
    sent = context.Queue()
    floods = []
    for kind_name, rate_hz in (("wind", wind_hz), ("grasp", grasp_hz)):
        ready = context.Event()
        process = context.Process(target=flood, args=(node + "/" + kind_name, kind_name, rate_hz, seconds, ready, go,
                                                      sent, measured), daemon=True)
        process.start()
        floods.append((kind_name, process, ready))
    try:
        if not rospy.core.is_initialized():
            rospy.init_node(CALLER[1:], argv=[], anonymous=True, disable_signals=True)
        pid = node_api(node).getPid(CALLER)[2]
        receiver = Receiver(node)
        for kind_name, process, ready in floods:
            if not ready.wait(READY_S):
                raise RuntimeError("the %s flooder did not connect to %s within %.0f s" % (kind_name, node, READY_S))
        if not wait_for(lambda: receiver.window(0.0, math.inf)[0], READY_S):
            raise RuntimeError("no %s/state within %.0f s" % (node, READY_S))
        time.sleep(WARMUP_S)  # a steady baseline: connections made, buffers allocated
        inputs = [node + "/wind", node + "/grasp"]
        stats_before = input_stats(node, inputs)
        rss_before = rss_kib(pid)
        rss_peak = rss_before
        cpu_before = cpu_s(pid)
        start = time.monotonic()
        go.set()
        rss_halfway = None
        while time.monotonic() - start < seconds:
            time.sleep(RSS_SAMPLE_S)
            rss_now = rss_kib(pid)
            rss_peak = max(rss_peak, rss_now)
            if rss_halfway is None and time.monotonic() - start >= seconds / 2:
                rss_halfway = rss_now  # growth that stops by half time is a plateau, not a leak
        end = time.monotonic()
        node_cpu = (cpu_s(pid) - cpu_before) / (end - start)
        load_average = os.getloadavg()[0]
        sent_rates = {}
        for _ in floods:
            kind_name, value = sent.get(timeout=READY_S)
            sent_rates[kind_name] = value
        rss_after = rss_kib(pid)
        stats_after = input_stats(node, inputs)
    finally:
        go.set()
        measured.set()
        for _, process, _ in floods:
            process.join(READY_S)
            if process.is_alive():
                process.terminate()
    states, meshes = receiver.window(start, end)
    periods_ms = sorted(1000.0 * (b[1] - a[1]) for a, b in zip(states, states[1:]))
    frames_per_s = (states[-1][2] - states[0][2]) / (states[-1][0] - states[0][0]) if len(states) > 1 else 0.0
    received = {}
    for topic in inputs:
        before = stats_before.get(topic, (0, 0))
        after = stats_after.get(topic, (0, 0))
        received[topic.rsplit("/", 1)[1]] = {"received": after[0] - before[0], "dropped": after[1] - before[1]}
    return {
        "seconds": end - start,
        "wind_sent_hz": sent_rates.get("wind", 0.0), "grasp_sent_hz": sent_rates.get("grasp", 0.0),
        "wind_target_hz": wind_hz, "grasp_target_hz": grasp_hz,
        "node_inputs": received,
        "state_hz": rate(states), "mesh_hz": rate(meshes), "frames_per_s": frames_per_s,
        "frame_period_ms": {"p50": percentile(periods_ms, 0.50), "p95": percentile(periods_ms, 0.95),
                            "p99": percentile(periods_ms, 0.99), "max": periods_ms[-1] if periods_ms else float("nan")},
        "node_cpu_share": node_cpu, "load_average": load_average, "cpus": os.cpu_count(),
        "rss_mib": {"before": rss_before / KIB_PER_MIB, "halfway": (rss_halfway or rss_before) / KIB_PER_MIB,
                    "after": rss_after / KIB_PER_MIB, "peak": rss_peak / KIB_PER_MIB},
    }


def report(figures, scene):
    period = figures["frame_period_ms"]
    rss = figures["rss_mib"]
    inputs = figures["node_inputs"]
    lines = [
        "load: %.1f s on %s; machine: %d CPUs, load average %.1f at the end" % (
            figures["seconds"], scene, figures["cpus"], figures["load_average"]),
        "  sent     ~wind %.0f msg/s (target %.0f), ~grasp %.0f msg/s (target %.0f)" % (
            figures["wind_sent_hz"], figures["wind_target_hz"], figures["grasp_sent_hz"], figures["grasp_target_hz"]),
    ]
    for name in ("wind", "grasp"):
        if name in inputs:
            lines.append("  node     ~%s: %d received, %d dropped by its bounded queue" % (
                name, inputs[name]["received"], inputs[name]["dropped"]))
    lines += [
        "  node CPU %.0f %% of one core" % (100.0 * figures["node_cpu_share"]),
        "  ~state   %.1f Hz received, %.1f frames/s advanced" % (figures["state_hz"], figures["frames_per_s"]),
        "  ~mesh    %.1f Hz received" % figures["mesh_hz"],
        "  frame period (~state stamps): p50 %.1f ms, p95 %.1f ms, p99 %.1f ms, max %.1f ms" % (
            period["p50"], period["p95"], period["p99"], period["max"]),
        "  node RSS %.1f MiB before, %.1f MiB halfway, %.1f MiB after (%+.1f MiB; %+.1f MiB in the second half), "
        "peak %.1f MiB" % (rss["before"], rss["halfway"], rss["after"], rss["after"] - rss["before"],
                           rss["after"] - rss["halfway"], rss["peak"]),
    ]
    return "\n".join(lines)


# ---- standalone: a master and a node of our own ----------------------------------------------------

def free_port():
    with socket.socket() as probe:
        probe.bind(("localhost", 0))
        return probe.getsockname()[1]


def start_master(log, caller, ready_s=READY_S):
    """A rosmaster on a free port, ROS_MASTER_URI pointing at it; returns its process once it answers."""
    port = free_port()
    os.environ["ROS_MASTER_URI"] = "http://localhost:%d" % port
    master = subprocess.Popen(["rosmaster", "--core", "-p", str(port)], stdout=log, stderr=subprocess.STDOUT)
    proxy = xmlrpc.client.ServerProxy(os.environ["ROS_MASTER_URI"])

    def answers():
        try:
            return proxy.getPid(caller)[0] == 1
        except OSError:
            return False
    if not wait_for(answers, ready_s):
        master.kill()
        master.wait()
        raise RuntimeError("rosmaster did not start")
    return master


def start_own_graph(rows, cols, log, node_log_path):
    """A rosmaster on a free port and a cloth_node on the hanging scene (its output in node_log_path); returns
    (master, node) processes. NodeExited if the node refuses to start."""
    master = start_master(log, CALLER)
    try:
        binary = subprocess.run(["catkin_find", "--first-only", "--libexec", "cloth_sim", "cloth_node"],
                                stdout=subprocess.PIPE, universal_newlines=True, check=True).stdout.strip()
        node = start_node(binary, ["_scene:=hanging", "_rows:=%d" % rows, "_cols:=%d" % cols], node_log_path,
                          master_proxy(), CALLER, READY_S)
    except BaseException:
        stop(master, signal.SIGINT)
        raise
    return master, node


def stop(process, signal_number):
    if process.poll() is None:
        process.send_signal(signal_number)
        try:
            return process.wait(NODE_EXIT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    return process.returncode


def check_arguments(parser, args):
    """parser.error (exit 2, one line naming the argument) for a number the measurement cannot use."""
    for option, value in (("--seconds", args.seconds), ("--wind-hz", args.wind_hz), ("--grasp-hz", args.grasp_hz)):
        # 0 Hz divided by zero in the flooder; 0 s measured nothing (nan periods); inf never ends.
        if not (math.isfinite(value) and value > 0):
            parser.error("%s must be a number above 0, not %s" % (option, value))
    if args.seconds < MIN_SECONDS:
        parser.error("--seconds must be at least %s (a shorter flood has too few frames to measure), not %s"
                     % (MIN_SECONDS, args.seconds))
    for option, value in (("--rows", args.rows), ("--cols", args.cols)):
        if not MIN_GRID_SIDE <= value <= MAX_GRID_SIDE:
            parser.error("%s must be a whole number from %d to %d (cloth_node's grid sides), not %d"
                         % (option, MIN_GRID_SIDE, MAX_GRID_SIDE, value))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--rows", type=int, default=64)
    parser.add_argument("--cols", type=int, default=64)
    parser.add_argument("--wind-hz", type=float, default=10000.0)
    parser.add_argument("--grasp-hz", type=float, default=1000.0)
    parser.add_argument("--attach", metavar="NODE", help="measure this running node instead of starting one")
    parser.add_argument("--json", metavar="FILE", help="also append the figures as one JSON line to FILE")
    args = parser.parse_args()
    check_arguments(parser, args)
    master = node = None
    log = open(os.devnull, "w")
    # The node's own output is kept (not sent to /dev/null with the master's): its FATAL line says why it
    # exited, if it does.
    folder = tempfile.mkdtemp(prefix="cloth_load_")
    node_log = os.path.join(folder, "cloth_node.log")
    try:
        if args.attach:
            name, scene = args.attach, "the running node %s" % args.attach
        else:
            master, node = start_own_graph(args.rows, args.cols, log, node_log)
            name, scene = "/cloth_node", "the hanging scene at %dx%d" % (args.rows, args.cols)
        try:
            figures = measure(name, args.seconds, args.wind_hz, args.grasp_hz)
        except RuntimeError:
            # A wait that ran out because the node had gone: its exit is the news, not the wait.
            if node is not None and node.poll() is not None:
                raise NodeExited(node_exit_message(node, node_log, "during the measurement"))
            raise
        if node is not None and node.poll() is not None:
            raise NodeExited(node_exit_message(node, node_log, "under the flood"))
    except RuntimeError as error:  # NodeExited among them: a message, not a traceback
        sys.exit("load.py: %s" % error)
    finally:
        if node is not None:
            exited_before = node.poll() is not None  # then already reported above, with its FATAL line
            exit_code = stop(node, signal.SIGTERM)
            if exit_code not in (0, None) and not exited_before:
                print("cloth_node exited with %s after SIGTERM" % exit_code, file=sys.stderr)
        if master is not None:
            stop(master, signal.SIGINT)
        shutil.rmtree(folder, ignore_errors=True)
    print(report(figures, scene))
    if args.json:
        figures["scene"] = scene
        with open(args.json, "a") as out:
            out.write(json.dumps(figures) + "\n")


if __name__ == "__main__":
    main()
