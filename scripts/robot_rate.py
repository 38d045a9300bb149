#!/usr/bin/python3
"""Does the node keep 50 Hz with a robot holding and touching the cloth? (issue 14's performance target)

Starts its own ROS master and a cloth_node on the hanging scene at ROWSxCOLS (top corners pinned) with N
capsule frame colliders (radius 3 cm, core 20 cm) lying along the cloth on the tf frames link_0 ...
link_<N-1>. Publishes those frames and two gripper frames in tf at 50 Hz (the capsules pressing 1 cm in
and out of the cloth at 1 Hz, the grippers circling 2 cm at 1 Hz), attaches the two grippers to the bottom
corners with ~attach, then counts ~state with cloth_topic_rate (C++) for SECONDS seconds and prints one JSON line:
the ~state rate, its period percentiles and the node's mean step cost from its diagnostics.

    scripts/robot_rate.py [--rows 64] [--cols 64] [--capsules 10] [--seconds 10]

Run it from a built workspace (make build; source its setup.bash) with /usr/bin first in PATH.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time

# Its master-and-node plumbing is load.py's, its measuring rates.py's (the scripts run from this folder).
from load import start_master, wait_for
from rates import MAX_SPAN_S, Diagnostics, measure_rates, summarise

CALLER = "/cloth_robot_rate"
READY_S = 30.0
CAPSULE_RADIUS_M = 0.03
CAPSULE_CORE_M = 0.2
PUBLISH_HZ = 50.0
MOTION_HZ = 1.0
GRIPPER_CIRCLE_M = 0.02
PRESS_M = 0.02  # the capsules' surfaces go from 1 cm off the cloth to 1 cm into it


def tool(name):
    """A built executable of the package (rosrun's search, without its prompt)."""
    found = subprocess.run(["catkin_find", "cloth_sim", name], stdout=subprocess.PIPE, universal_newlines=True)
    paths = [line for line in found.stdout.splitlines() if os.access(line, os.X_OK)]
    if not paths:
        raise RuntimeError("%s is not built: run make build and source the workspace" % name)
    return paths[0]


def rest_position(particle, cols, rows):
    """The hanging scene's rest grid: 1 m square in the x-z plane, top-left corner at (-0.5, 0, 1.5)."""
    row, col = divmod(particle, cols)
    return (-0.5 + col / (cols - 1.0), 0.0, 1.5 - row / (rows - 1.0))


def capsule_frames(count, rows, cols):
    """Where capsule k lies: over particle (share rows, share cols), its z axis along x (the cloth's u)."""
    frames = []
    for k in range(count):
        share = (k + 1.0) / (count + 1.0)
        particle = int(share * (rows - 1)) * cols + int(share * (cols - 1))
        frames.append(rest_position(particle, cols, rows))
    return frames


def publish_frames(stop, rows, cols, capsules):
    import rospy
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    publisher = rospy.Publisher("/tf", TFMessage, queue_size=100)
    homes = capsule_frames(capsules, rows, cols)
    corners = [rest_position((rows - 1) * cols, cols, rows), rest_position(rows * cols - 1, cols, rows)]
    half_turn_about_y = (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))  # x, y, z, w: the capsule's z along world x
    rate = rospy.Rate(PUBLISH_HZ)
    start = time.monotonic()
    while not stop.is_set() and not rospy.is_shutdown():
        phase = 2.0 * math.pi * MOTION_HZ * (time.monotonic() - start)
        now = rospy.Time.now()
        transforms = []

        def frame(name, position, rotation=(0.0, 0.0, 0.0, 1.0)):
            t = TransformStamped()
            t.header.stamp = now
            t.header.frame_id = "world"
            t.child_frame_id = name
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = position
            (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
             t.transform.rotation.w) = rotation
            transforms.append(t)

        press = PRESS_M * 0.5 * (1.0 - math.cos(phase))
        for k, (x, y, z) in enumerate(homes):
            frame("link_%d" % k, (x, y + CAPSULE_RADIUS_M + 0.01 - press, z), half_turn_about_y)
        for k, (x, y, z) in enumerate(corners):
            frame("gripper_%d" % k, (x + GRIPPER_CIRCLE_M * (math.cos(phase) - 1.0), y + GRIPPER_CIRCLE_M * math.sin(phase), z))
        publisher.publish(TFMessage(transforms=transforms))
        rate.sleep()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=64)
    parser.add_argument("--cols", type=int, default=64)
    parser.add_argument("--capsules", type=int, default=10)
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    if not (math.isfinite(args.seconds) and 0 < args.seconds <= MAX_SPAN_S):
        parser.error("--seconds must be a number of seconds in (0, %g], not %s" % (MAX_SPAN_S, args.seconds))

    log = tempfile.TemporaryFile()
    master = start_master(log, CALLER)
    node = None
    stop = threading.Event()
    try:
        import rospy
        from cloth_sim.srv import Attach, AttachRequest
        rospy.init_node(CALLER.lstrip("/"), disable_signals=True)
        # Lists go through the parameter server (a _name:=value argument reaches roscpp as a string).
        rospy.set_param("/cloth_node/frame_colliders",
                        [{"frame": "link_%d" % k, "shape": "capsule", "radius": CAPSULE_RADIUS_M,
                          "length": CAPSULE_CORE_M} for k in range(args.capsules)])
        node = subprocess.Popen([tool("cloth_node"), "__name:=cloth_node", "_scene:=hanging", "_rows:=%d" % args.rows,
                                 "_cols:=%d" % args.cols], stdout=log, stderr=subprocess.STDOUT)
        rospy.wait_for_service("/cloth_node/attach", READY_S)
        publisher = threading.Thread(target=publish_frames, args=(stop, args.rows, args.cols, args.capsules), daemon=True)
        publisher.start()
        attach = rospy.ServiceProxy("/cloth_node/attach", Attach)
        bottom = (args.rows - 1) * args.cols
        for gripper, particle in ((0, bottom), (1, bottom + args.cols - 1)):
            request = AttachRequest(id=gripper, frame="gripper_%d" % gripper, radius=0.0, particles=[particle], max_force=0.0)
            if not wait_for(lambda: attach(request).success, READY_S, period_s=0.2):
                raise RuntimeError("~attach never accepted gripper_%d" % gripper)
        diagnostics = Diagnostics()
        diagnostics.start()
        topics = measure_rates(tool("cloth_topic_rate"), ["/cloth_node/state"], args.seconds)
        figures = summarise(diagnostics.stop())
        state = topics["/cloth_node/state"]
        print(json.dumps({"rows": args.rows, "cols": args.cols, "grippers": 2, "capsules": args.capsules,
                          "state_rate_hz": state.get("rate_hz"), "period_ms": state.get("period_ms"),
                          "step_cost_ms": figures["step_cost_ms"], "real_time_factor": figures["real_time_factor"],
                          "diagnostics": figures["message"]}))
        return 0
    finally:
        stop.set()
        for process in (node, master):
            if process is not None:
                process.terminate()
                process.wait()


if __name__ == "__main__":
    sys.exit(main())
