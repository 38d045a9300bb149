#!/usr/bin/python3
"""What rate each built-in scene really publishes at, to a C++ subscriber (issue 13, `make rates`).

Starts its own ROS master on a free port, then for every scene (config/scenes/*.yaml, or --scenes) and size
(--sizes, default 64 and 128 particles per side; everything else the scene's own defaults) a cloth_node,
and measures with cloth_topic_rate (C++, any type; rostopic hz cannot keep up with a 128x128 ClothState):
  1. ~state alone for --seconds: the rate a state subscriber (the ClothState rviz display, a recorder,
     a controller) gets, with the node's own diagnostics over that window (mean wall time per frame, the
     real-time factor, and its status: WARN when the physics does not fit in the 20 ms frame);
  2. ~state and ~mesh together for --seconds: what a ~mesh subscriber (rviz's Marker display) costs the
     node.
Prints a markdown table (doc/BENCHMARKS.md quotes it); --json FILE appends one JSON line per run.
--rviz marker|plugin also runs rviz (under its own Xvfb, software GL) with config/cloth.rviz drawing the
cloth from the ~mesh marker (rviz/Marker) or from ~state (the package's cloth_sim/ClothState display), and
measures once rviz has subscribed: what drawing the cloth in rviz costs the node. --paused pauses the node
first (~pause: it republishes every frame, no physics), so only publishing and viewing are measured. The
node's and rviz's CPU time over the first window are reported in % of one core, and the share of the node's
statuses over that window that said the cloth was asleep (sleep_speed). --skip S starts the first window S
seconds after the first message (default 2: past the start-up; 20: the scenes at rest). --queue N is the
rate tool's subscriber queue (default 6: cloth_node sends the frames a late tick caught up on back to back,
up to 6, and a queue of 1 would count only the last of them; 1 counts what a newest-only subscriber gets).
Needs the package built and its devel/setup.bash sourced (make rates does both).
"""
import argparse
import glob
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import xmlrpc.client

# Its master-and-node plumbing is load.py's (the scripts run from this folder).
from load import MAX_GRID_SIDE, MIN_GRID_SIDE, NodeExited, node_exit_message, start_master, start_node, wait_for

CALLER = "/cloth_rates"
READY_S = 60.0        # a 128x128 scene builds and its node registers within this
STOP_S = 10.0
# cloth_node's ~state queue (ClothNode::kStateQueue): a wall-time tick sends up to this many frames.
STATE_QUEUE = 6
# cloth_topic_rate's --queue range (its kMaxQueue): refused up front rather than by the tool mid-run.
MIN_QUEUE = 1
MAX_QUEUE = 1000
# cloth_topic_rate's longest --seconds and --skip, s (its kMaxTopicSpan_s), refused up front too.
MAX_SPAN_S = 86400.0
# How often the node is checked while the rate tool waits for its messages: a node that exits is news at once,
# not after the tool's READY_S wait for a first message.
NODE_POLL_S = 0.2
SKIP_S = 2.0          # start-up frames (the scene's first solves, connections) are left out
STATUS_NAME = "cloth_node: simulation"
RVIZ_SCREEN = "1000x720x24"
# The displays of config/cloth.rviz that draw the cloth: from ~state (the plugin) and from ~mesh.
RVIZ_DISPLAYS = {"plugin": "cloth_sim/ClothState", "marker": "rviz/Marker"}
RVIZ_TOPICS = {"plugin": "/cloth_node/state", "marker": "/cloth_node/mesh"}


def find_executable(name):
    return subprocess.run(["catkin_find", "--first-only", "--libexec", "cloth_sim", name], stdout=subprocess.PIPE,
                          universal_newlines=True, check=True).stdout.strip()


def stop(process, signal_number=signal.SIGINT):
    if process.poll() is None:
        process.send_signal(signal_number)
        try:
            process.wait(STOP_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


class Diagnostics:
    """The node's statuses on /diagnostics, kept between start() and stop()."""

    def __init__(self):
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        self.lock = threading.Lock()
        self.recording = False
        self.statuses = []
        self.subscriber = rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_array, queue_size=20)

    def on_array(self, array):
        with self.lock:
            if self.recording:
                self.statuses += [s for s in array.status if s.name == STATUS_NAME]

    def start(self):
        with self.lock:
            self.statuses, self.recording = [], True

    def stop(self):
        with self.lock:
            self.recording = False
            return list(self.statuses)


def summarise(statuses):
    """Mean step cost (ms) and real-time factor over the windows, and the last status's level and message."""
    def mean_of(key):
        numbers = []
        for status in statuses:
            for entry in status.values:
                if entry.key == key:
                    try:
                        numbers.append(float(entry.value))
                    except ValueError:
                        pass
        return sum(numbers) / len(numbers) if numbers else None
    cost = mean_of("mean step cost [ms]")
    if cost is None:
        cost = mean_of("step cost [ms]")
    last = statuses[-1] if statuses else None
    levels = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
    asleep = [entry.value == "True" for status in statuses for entry in status.values if entry.key == "asleep"]
    return {"step_cost_ms": cost, "real_time_factor": mean_of("real-time factor"),
            "asleep_share": sum(asleep) / len(asleep) if asleep else None,
            "level": levels.get(ord(last.level) if isinstance(last.level, bytes) else last.level) if last else None,
            "message": last.message if last else None}


def measure_rates(rate_tool, topics, seconds, skip_s=SKIP_S, queue=1, node=None, node_log=None):
    """cloth_topic_rate's figures for `topics`; NodeExited (with its FATAL line from node_log) if `node`, the
    node's process where this program started it, exits meanwhile."""
    tool = subprocess.Popen([rate_tool, "--seconds", str(seconds), "--skip", str(skip_s), "--wait", str(READY_S),
                             "--queue", str(queue)] + topics,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    while True:
        try:
            stdout, stderr = tool.communicate(timeout=NODE_POLL_S)  # retried: no output is lost
            break
        except subprocess.TimeoutExpired:
            if node is not None and node.poll() is not None:
                stop(tool)
                tool.communicate()
                raise NodeExited(node_exit_message(node, node_log, "while its rates were measured"))
    lines = [line for line in stdout.splitlines() if line.startswith("{")]
    if not lines:
        if node is not None and node.poll() is not None:
            raise NodeExited(node_exit_message(node, node_log, "while its rates were measured"))
        raise RuntimeError("cloth_topic_rate printed nothing: " + stderr[-500:])
    return json.loads(lines[-1])["topics"]


def rviz_config(mode, folder):
    """config/cloth.rviz with only the cloth display of `mode` enabled; its path."""
    import yaml
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "..", "config", "cloth.rviz")) as source:
        config = yaml.safe_load(source)
    for display in config["Visualization Manager"]["Displays"]:
        if display["Class"] in RVIZ_DISPLAYS.values():
            display["Enabled"] = display["Value"] = display["Class"] == RVIZ_DISPLAYS[mode]
    path = os.path.join(folder, "rates_%s.rviz" % mode)
    with open(path, "w") as out:
        yaml.safe_dump(config, out)
    return path


def start_rviz(mode, proxy, log, folder):
    """Xvfb and rviz drawing the cloth by `mode`; returns the processes once rviz subscribes to its topic."""
    display = ":%d" % (100 + os.getpid() % 100)
    xvfb = subprocess.Popen(["Xvfb", display, "-screen", "0", RVIZ_SCREEN], stdout=log, stderr=subprocess.STDOUT)
    environment = dict(os.environ, DISPLAY=display, LIBGL_ALWAYS_SOFTWARE="1")
    rviz = subprocess.Popen(["rviz", "-d", rviz_config(mode, folder), "__name:=rviz_rates"], env=environment,
                            stdout=log, stderr=subprocess.STDOUT)

    def subscribed():
        _, _, (_, subscribers, _) = proxy.getSystemState(CALLER)
        return any(topic == RVIZ_TOPICS[mode] and "/rviz_rates" in nodes for topic, nodes in subscribers)
    if not wait_for(subscribed, READY_S, period_s=0.5) or rviz.poll() is not None:
        stop(rviz)
        stop(xvfb)
        raise RuntimeError("rviz did not subscribe to %s" % RVIZ_TOPICS[mode])
    return [rviz, xvfb]


def cpu_s(pid):
    """CPU time (user + system) the process has used so far, s."""
    with open("/proc/%d/stat" % pid) as stat:
        fields = stat.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def pause(node_name, paused):
    import rospy
    from std_srvs.srv import SetBool
    rospy.wait_for_service(node_name + "/pause", READY_S)
    answer = rospy.ServiceProxy(node_name + "/pause", SetBool)(paused)
    if not answer.success:
        raise RuntimeError("~pause refused: " + answer.message)


def run_one(node_binary, rate_tool, diagnostics, proxy, scene, side, seconds, node_log, start_viewers, paused,
            skip_s, queue):
    # The node's output goes to node_log: if it exits (a scene or size it refuses), its FATAL line says why.
    node = start_node(node_binary, ["_scene:=" + scene, "_rows:=%d" % side, "_cols:=%d" % side], node_log, proxy,
                      CALLER, READY_S)
    try:
        if paused:
            pause("/cloth_node", True)
        viewers = start_viewers()
        diagnostics.start()
        watched = {"node": node.pid, "rviz": viewers[0].pid if viewers else None}
        cpu_before = {name: cpu_s(pid) for name, pid in watched.items() if pid}
        wall_before = time.monotonic()
        alone = measure_rates(rate_tool, ["/cloth_node/state"], seconds, skip_s, queue, node,
                              node_log)["/cloth_node/state"]
        wall_s = time.monotonic() - wall_before
        # CPU share over the whole measurement (cloth_topic_rate's start-up skip included), % of one core.
        cpu = {name + "_cpu_percent": 100.0 * (cpu_s(watched[name]) - before) / wall_s
               for name, before in cpu_before.items()}
        health = summarise(diagnostics.stop())
        both = measure_rates(rate_tool, ["/cloth_node/state", "/cloth_node/mesh"], seconds, SKIP_S, queue, node,
                             node_log)
    finally:
        stop(node)
    return {"scene": scene, "rows": side, "cols": side, "seconds": seconds, "paused": paused, "queue": queue,
            "state_hz": alone["rate_hz"], "state_period_ms": alone["period_ms"], "state_bytes": alone["bytes"],
            "state_hz_with_mesh": both["/cloth_node/state"]["rate_hz"],
            "mesh_hz": both["/cloth_node/mesh"]["rate_hz"], "mesh_bytes": both["/cloth_node/mesh"]["bytes"],
            **cpu, **health}


def fmt(value, digits=1):
    return "-" if value is None else "%.*f" % (digits, value)


def table(runs):
    lines = ["| scene | grid | ~state Hz | period p50 / p99 ms | step cost ms | real-time factor | "
             "~state Hz with ~mesh | ~mesh Hz | node CPU % | rviz CPU % | asleep | diagnostics |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for run in runs:
        status = run["level"] or "-"
        if run["level"] not in (None, "OK") and run["message"]:
            status += ": " + run["message"]
        lines.append("| %s | %dx%d | %s | %s / %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            run["scene"], run["rows"], run["cols"], fmt(run["state_hz"]), fmt(run["state_period_ms"]["p50"]),
            fmt(run["state_period_ms"]["p99"]), fmt(run["step_cost_ms"]), fmt(run["real_time_factor"], 2),
            fmt(run["state_hz_with_mesh"]), fmt(run["mesh_hz"]), fmt(run.get("node_cpu_percent"), 0),
            fmt(run.get("rviz_cpu_percent"), 0),
            "-" if run.get("asleep_share") is None else "%.0f %%" % (100.0 * run["asleep_share"]), status))
    return "\n".join(lines)


def check_arguments(parser, args):
    """(scenes, sizes) from the arguments; parser.error (exit 2, one line naming the argument) for a value the
    runs cannot use, before any node starts."""
    scenes = [s for s in args.scenes.split(",") if s]
    if not scenes:
        parser.error("--scenes must name at least one scene")
    sizes = []
    for text in [t for t in args.sizes.split(",") if t]:  # empty items skipped, as --scenes's are
        try:
            side = int(text)
        except ValueError:
            side = None
        if side is None or not MIN_GRID_SIDE <= side <= MAX_GRID_SIDE:
            parser.error("--sizes must be whole numbers from %d to %d (cloth_node's grid sides), comma-separated; "
                         "not '%s'" % (MIN_GRID_SIDE, MAX_GRID_SIDE, text))
        sizes.append(side)
    if not sizes:
        parser.error("--sizes must name at least one grid side")
    if not (math.isfinite(args.seconds) and 0 < args.seconds <= MAX_SPAN_S):
        parser.error("--seconds must be a number of seconds in (0, %g], not %s" % (MAX_SPAN_S, args.seconds))
    if not (math.isfinite(args.skip) and 0 <= args.skip <= MAX_SPAN_S):
        parser.error("--skip must be a number of seconds in [0, %g], not %s" % (MAX_SPAN_S, args.skip))
    if not MIN_QUEUE <= args.queue <= MAX_QUEUE:
        parser.error("--queue must be a whole number from %d to %d, not %d" % (MIN_QUEUE, MAX_QUEUE, args.queue))
    return scenes, sizes


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    builtin = sorted(os.path.basename(p)[:-5] for p in glob.glob(os.path.join(here, "..", "config", "scenes", "*.yaml")))
    parser.add_argument("--scenes", default=",".join(builtin), help="comma-separated (default: every built-in scene)")
    parser.add_argument("--sizes", default="64,128", help="particles per side, comma-separated")
    parser.add_argument("--seconds", type=float, default=5.0, help="measured seconds of each of the two windows")
    parser.add_argument("--skip", type=float, default=SKIP_S,
                        help="seconds of ~state left out before the first window (default %(default)s: the start-up); "
                             "e.g. 20 to measure the scenes once they have come to rest (and may sleep)")
    parser.add_argument("--queue", type=int, default=STATE_QUEUE, metavar="N",
                        help="the rate tool's subscriber queue, %d to %d (default %%(default)s: every frame of a "
                             "catching-up tick)" % (MIN_QUEUE, MAX_QUEUE))
    parser.add_argument("--json", metavar="FILE", help="also append each run as one JSON line to FILE")
    parser.add_argument("--rviz", choices=["none", "marker", "plugin"], default="none",
                        help="also run rviz drawing the cloth from ~mesh (marker) or from ~state (plugin)")
    parser.add_argument("--paused", action="store_true",
                        help="pause the node (~pause) first: it republishes every frame without physics, so the "
                             "rates show what publishing and viewing alone cost")
    args = parser.parse_args()
    scenes, sizes = check_arguments(parser, args)

    log = open(os.devnull, "w")
    folder = tempfile.mkdtemp(prefix="cloth_rates_")
    master = start_master(log, CALLER, READY_S)
    runs = []
    try:
        proxy = xmlrpc.client.ServerProxy(os.environ["ROS_MASTER_URI"])
        import rospy
        rospy.init_node("cloth_rates", anonymous=True, disable_signals=True)
        diagnostics = Diagnostics()
        node_binary, rate_tool = find_executable("cloth_node"), find_executable("cloth_topic_rate")
        for side in sizes:
            for scene in scenes:
                print("==> rates: %s at %dx%d" % (scene, side, side), file=sys.stderr, flush=True)
                viewers = []

                def start_viewers():
                    if args.rviz != "none":
                        viewers.extend(start_rviz(args.rviz, proxy, log, folder))
                    return viewers
                try:
                    run = run_one(node_binary, rate_tool, diagnostics, proxy, scene, side, args.seconds,
                                  os.path.join(folder, "cloth_node.log"), start_viewers, args.paused, args.skip,
                                  args.queue)
                finally:
                    for process in viewers:
                        stop(process)
                run["rviz"] = args.rviz
                runs.append(run)
                if args.json:
                    with open(args.json, "a") as out:
                        out.write(json.dumps(run) + "\n")
    except RuntimeError as error:  # NodeExited among them: a message (after the runs that did finish), no traceback
        if runs:
            print(table(runs))
        sys.exit("rates.py: %s" % error)
    finally:
        stop(master)
        shutil.rmtree(folder, ignore_errors=True)
    if args.paused:
        print("paused: every frame republished, no physics")
    if args.rviz != "none":
        print("rviz drawing the cloth from %s (%s)" % (RVIZ_TOPICS[args.rviz], RVIZ_DISPLAYS[args.rviz]))
    print(table(runs))


if __name__ == "__main__":
    main()
