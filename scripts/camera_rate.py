#!/usr/bin/python3
"""Measures a running cloth_node with a depth camera: the ~state rate, the camera's image rate, and what the
node itself reports (real-time factor, step cost, render cost) over a window of wall time.

    roslaunch -p 11421 cloth_sim cloth.launch camera:=true rows:=64 cols:=64 &
    ROS_MASTER_URI=http://localhost:11421 scripts/camera_rate.py --seconds 30

Topics are taken as rospy.AnyMsg (never deserialised), so this subscriber is not the bottleneck that a
Python deserialiser of 640x480 images and 64x64 states would be; the node still serialises and sends
every message. Prints one JSON line.
"""
import argparse
import json
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--node", default="/cloth_node")
    parser.add_argument("--camera", default="front")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--settle", type=float, default=5.0, help="seconds to wait before counting")
    parser.add_argument("--points", action="store_true", help="also subscribe to the camera's depth/points")
    parser.add_argument("--without-camera", action="store_true",
                        help="subscribe to ~state only (the camera then renders nothing): the baseline")
    args = parser.parse_args()
    rospy.init_node("camera_rate", anonymous=True)

    lock = threading.Lock()
    counts = {}
    diagnostics = []

    def counter(name):
        counts[name] = 0

        def received(_):
            with lock:
                counts[name] += 1
        return received

    topics = {"state": args.node + "/state"}
    if not args.without_camera:
        topics["depth"] = "%s/%s/depth/image_raw" % (args.node, args.camera)
    if args.points and not args.without_camera:
        topics["points"] = "%s/%s/depth/points" % (args.node, args.camera)
    subscribers = [rospy.Subscriber(topic, rospy.AnyMsg, counter(name), queue_size=1, buff_size=1 << 24)
                   for name, topic in topics.items()]

    def on_diagnostics(array):
        values = {}
        for status in array.status:
            for pair in status.values:
                values[pair.key] = pair.value
        with lock:
            diagnostics.append((time.monotonic(), values))

    rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=10)
    time.sleep(args.settle)
    with lock:
        for name in counts:
            counts[name] = 0
        del diagnostics[:]
    start = time.monotonic()
    time.sleep(args.seconds)
    with lock:
        elapsed = time.monotonic() - start
        rates = {name + "_hz": round(count / elapsed, 2) for name, count in counts.items()}
        window = [values for _, values in diagnostics]
        first, last = diagnostics[0], diagnostics[-1]
    images_key = args.camera + " images"
    result = dict(rates)
    result["seconds"] = round(elapsed, 1)
    result["camera_images_hz_node"] = round(
        (int(last[1][images_key]) - int(first[1][images_key])) / (last[0] - first[0]), 2)
    for key, name in (("real-time factor", "real_time_factor"), ("step cost [ms]", "step_cost_ms"),
                      (args.camera + " render cost [ms]", "render_cost_ms")):
        samples = sorted(float(v[key]) for v in window if key in v)
        if not samples:
            continue
        result[name + "_median"] = round(samples[len(samples) // 2], 3)
        result[name + "_min"] = round(samples[0], 3)
    print(json.dumps(result))
    for subscriber in subscribers:
        subscriber.unregister()


if __name__ == "__main__":
    main()
