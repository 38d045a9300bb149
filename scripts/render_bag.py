#!/usr/bin/python3
"""Render the last cloth mesh Marker in a rosbag to a PNG, and report how often it was published.

    render_bag.py BAG OUT.png [--topic /cloth_node/mesh] [--title TEXT]

The mesh is a visualization_msgs/Marker TRIANGLE_LIST (three points per triangle, optional per-vertex
colours) in a z-up frame. The picture is a 3D view with each triangle filled with the mean of its vertex
colours, lightly shaded by its normal so folds read, over a floor hint at z = 0. The title is TEXT (default:
the bag's file name) and the simulated time of the frame: ClothState.sim_time from the bag when it holds a
cloth_sim/ClothState topic, else the Marker's header stamp relative to the first mesh in the bag.

Also prints one line with the mesh publish rate measured from the bag's receive timestamps (and from the
header stamps). Exit status 1 when the bag has no usable mesh.

Runs with Debian's /usr/bin/python3 (python3-rosbag, python3-matplotlib, python3-numpy); no ROS
workspace needed: rosbag rebuilds message classes from the definitions stored in the bag.
"""
import argparse
import collections
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import rosbag  # noqa: E402

TRIANGLE_LIST = 11  # visualization_msgs/Marker.TRIANGLE_LIST
MARKER_ADD = 0


def quat_to_matrix(q):
    x, y, z, w = q.x, q.y, q.z, q.w
    n = x * x + y * y + z * z + w * w
    if not math.isfinite(n) or n < 1e-12:  # an all-zero quaternion: rviz treats it as identity
        return np.eye(3)
    s = 2.0 / n
    return np.array([
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ])


def marker_triangles(marker):
    """(T, 3, 3) vertex positions in the marker's frame and (T, 4) RGBA face colours, finite only."""
    pts = np.array([[p.x, p.y, p.z] for p in marker.points], dtype=float)
    ntri = len(pts) // 3
    pts = pts[:ntri * 3]
    scale = np.array([marker.scale.x, marker.scale.y, marker.scale.z], dtype=float)
    if not np.all(np.isfinite(scale)) or np.all(scale == 0):
        scale = np.ones(3)
    pose = marker.pose
    rot = quat_to_matrix(pose.orientation)
    offset = np.array([pose.position.x, pose.position.y, pose.position.z])
    world = (pts * scale) @ rot.T + offset
    tris = world.reshape(ntri, 3, 3)
    if len(marker.colors) >= ntri * 3:
        vcol = np.array([[c.r, c.g, c.b, c.a] for c in marker.colors[:ntri * 3]], dtype=float)
        fcol = vcol.reshape(ntri, 3, 4).mean(axis=1)
    else:
        c = marker.color
        fcol = np.tile([c.r, c.g, c.b, c.a], (ntri, 1)).astype(float)
    fcol = np.clip(np.nan_to_num(fcol, nan=0.5), 0.0, 1.0)
    fcol[:, 3] = np.where(fcol[:, 3] <= 0.0, 1.0, fcol[:, 3])  # alpha 0 means "unset" in most publishers
    ok = np.all(np.isfinite(tris), axis=(1, 2))
    return tris[ok], fcol[ok], int(ntri - ok.sum())


def shade(tris, colors):
    """Lambert-ish shading (two-sided) so that the cloth's folds are visible in a still picture."""
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    light = np.array([0.3, -0.5, 0.8])
    light /= np.linalg.norm(light)
    k = 0.55 + 0.45 * np.abs(n @ light)
    out = colors.copy()
    out[:, :3] *= k[:, None]
    return out


# A particle whose velocity is exactly zero in each of the last this many recorded states counts as pinned:
# the node sets a fixed pin's velocity to exactly 0, while a free particle keeps some rounding-level speed.
PIN_STATES = 25


def pinned_points(last_states):
    """Positions, in the last state, of the particles pinned in the recording: (n x 3), m."""
    if len(last_states) < PIN_STATES:
        return np.zeros((0, 3))
    still = np.all([np.all(velocities == 0.0, axis=1) for _, velocities in last_states], axis=0)
    return last_states[-1][0][still]


MARKER_CUBE, MARKER_SPHERE, MARKER_CYLINDER = 1, 2, 3
# Collider namespaces drawn (cloth_node's ~colliders): the scene's boxes and spheres and the robot's links.
DRAWN_COLLIDERS = ("boxes", "spheres", "frame_colliders")
LINK_COLOR = "tab:orange"


def draw_colliders(ax, array):
    """The boxes, spheres and links of a ~colliders MarkerArray: boxes as wire frames, a capsule's cylinder
    as a thick segment along its axis, spheres as dots (planes are left to the floor hint)."""
    for marker in array.markers if array is not None else []:
        if marker.ns not in DRAWN_COLLIDERS or marker.action != MARKER_ADD:
            continue
        rot = quat_to_matrix(marker.pose.orientation)
        centre = np.array([marker.pose.position.x, marker.pose.position.y, marker.pose.position.z])
        size = np.array([marker.scale.x, marker.scale.y, marker.scale.z])
        color = LINK_COLOR if marker.ns == "frame_colliders" else "0.35"
        if marker.type == MARKER_CUBE:
            corners = np.array([[sx, sy, sz] for sx in (-0.5, 0.5) for sy in (-0.5, 0.5) for sz in (-0.5, 0.5)])
            world = (corners * size) @ rot.T + centre
            for a in range(8):
                for b in range(a + 1, 8):
                    if bin(a ^ b).count("1") == 1:  # corners differing along one axis: an edge
                        ax.plot(*zip(world[a], world[b]), color=color, lw=1.2)
        elif marker.type == MARKER_CYLINDER:
            ends = np.array([[0, 0, -0.5 * size[2]], [0, 0, 0.5 * size[2]]]) @ rot.T + centre
            ax.plot(*zip(ends[0], ends[1]), color=color, lw=6, solid_capstyle="round")
        elif marker.type == MARKER_SPHERE:
            ax.scatter([centre[0]], [centre[1]], [centre[2]], s=30, c=color, depthshade=False)


def read_bag(path, topic):
    meshes = []  # (bag time s, header stamp s, marker)
    states = []  # (bag time s, sim_time s)
    last_states = collections.deque(maxlen=PIN_STATES)  # (positions, velocities), rows * cols x 3 each
    with rosbag.Bag(path) as bag:
        info = bag.get_type_and_topic_info().topics
        if topic not in info:
            have = ", ".join("%s (%s)" % (t, i.msg_type) for t, i in sorted(info.items())) or "nothing"
            raise SystemExit("render_bag: %s has no topic %s; it has %s" % (path, topic, have))
        state_topics = [t for t, i in info.items() if i.msg_type == "cloth_sim/ClothState"]
        for t, msg, stamp in bag.read_messages(topics=[topic] + state_topics):
            if t == topic:
                meshes.append((stamp.to_sec(), msg.header.stamp.to_sec(), msg))
            elif math.isfinite(msg.sim_time):
                states.append((stamp.to_sec(), msg.sim_time))
                last_states.append((np.array([[p.x, p.y, p.z] for p in msg.positions]),
                                    np.array([[v.x, v.y, v.z] for v in msg.velocities])))
    return meshes, states, list(last_states)


def last_colliders(path, topic, before_s):
    """The last ~colliders MarkerArray recorded at or before bag time before_s, or None."""
    last = None
    with rosbag.Bag(path) as bag:
        if topic not in bag.get_type_and_topic_info().topics:
            return None
        for _, msg, stamp in bag.read_messages(topics=[topic]):
            if stamp.to_sec() <= before_s + 1e-6:
                last = msg
    return last


def rate(times):
    if len(times) < 2 or times[-1] <= times[0]:
        return float("nan")
    return (len(times) - 1) / (times[-1] - times[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("bag", metavar="BAG")
    ap.add_argument("out", metavar="OUT.png")
    ap.add_argument("--topic", default="/cloth_node/mesh")
    ap.add_argument("--no-pins", action="store_true",
                    help="do not mark still particles as pins (a cloth resting on a table is still too)")
    ap.add_argument("--title", default=None, help="picture title (default: the bag's file name)")
    ap.add_argument("--dpi", type=int, default=110)
    args = ap.parse_args(argv)
    # Refused here in one line each, not as a traceback from rosbag or from savefig at the end.
    if not os.path.isfile(args.bag):
        ap.error("BAG %s: no such file" % args.bag)
    out_folder = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(out_folder):
        ap.error("OUT.png %s: no folder %s" % (args.out, out_folder))

    try:
        meshes, states, last_states = read_bag(args.bag, args.topic)
    except (rosbag.ROSBagException, OSError) as error:  # not a bag, a truncated one, unreadable
        print("render_bag: %s: %s" % (args.bag, error), file=sys.stderr)
        return 1
    usable = [m for m in meshes if m[2].type == TRIANGLE_LIST and m[2].action == MARKER_ADD and len(m[2].points) >= 3]
    if not usable:
        print("render_bag: %s: %d messages on %s, none a non-empty TRIANGLE_LIST" % (args.bag, len(meshes), args.topic),
              file=sys.stderr)
        return 1

    bag_times = [m[0] for m in meshes]
    stamps = [m[1] for m in meshes]
    print("%s publish rate: %.1f Hz (%d messages over %.2f s of bag time; from header stamps: %.1f Hz)" % (
        args.topic, rate(bag_times), len(meshes), bag_times[-1] - bag_times[0], rate(stamps)))

    t_bag, t_stamp, marker = usable[-1]
    if marker.header.frame_id.lstrip("/") != "world":
        print("render_bag: warning: mesh frame is '%s', drawn as if it were 'world' (z up)" % marker.header.frame_id,
              file=sys.stderr)
    tris, colors, dropped = marker_triangles(marker)
    if dropped:
        print("render_bag: warning: %d triangles with non-finite vertices left out" % dropped, file=sys.stderr)
    if len(tris) == 0:
        print("render_bag: the last mesh has no finite triangle", file=sys.stderr)
        return 1

    earlier = [s for s in states if s[0] <= t_bag + 1e-6]
    if earlier:
        time_label = "sim time %.2f s" % earlier[-1][1]
    else:
        time_label = "t = %.2f s (stamp since first mesh)" % (t_stamp - stamps[0])
    title = args.title if args.title else os.path.splitext(os.path.basename(args.bag))[0]

    fig = plt.figure(figsize=(7.5, 6))
    ax = fig.add_subplot(111, projection="3d")
    colliders = last_colliders(args.bag, args.topic.rsplit("/", 1)[0] + "/colliders", t_bag)
    flat = tris.reshape(-1, 3)
    links = [m for m in (colliders.markers if colliders is not None else []) if m.ns == "frame_colliders"]
    if links:  # the robot's links are in the picture too
        flat = np.vstack([flat, [[m.pose.position.x, m.pose.position.y, m.pose.position.z] for m in links]])
    lo, hi = flat.min(axis=0), flat.max(axis=0)
    # The floor: z = 0 (the plane the scenes' potential energy and floor contacts are measured from),
    # drawn under the cloth with a margin; if the cloth is far above it, the floor still anchors the view.
    span = max(float(np.max(hi[:2] - lo[:2])), 0.2)
    cx, cy = (lo[:2] + hi[:2]) / 2
    half = 0.5 * span + 0.25 * span
    fx0, fx1, fy0, fy1 = cx - half, cx + half, cy - half, cy + half
    floor_z = min(0.0, float(lo[2]))
    floor = Poly3DCollection([[(fx0, fy0, floor_z), (fx1, fy0, floor_z), (fx1, fy1, floor_z), (fx0, fy1, floor_z)]],
                             facecolors=(0.55, 0.55, 0.55, 0.25), edgecolors="none")
    ax.add_collection3d(floor)
    for g in np.linspace(-half, half, 9):
        ax.plot([cx + g, cx + g], [fy0, fy1], [floor_z, floor_z], color="0.55", lw=0.5, alpha=0.6)
        ax.plot([fx0, fx1], [cy + g, cy + g], [floor_z, floor_z], color="0.55", lw=0.5, alpha=0.6)

    faces = shade(tris, colors)
    # Edges in the face colour hide the anti-aliasing seams between neighbouring triangles.
    cloth = Poly3DCollection(list(tris), facecolors=faces, edgecolors=faces, linewidths=0.3)
    ax.add_collection3d(cloth)

    draw_colliders(ax, colliders)

    pins = np.zeros((0, 3)) if args.no_pins else pinned_points(last_states)
    if len(pins):
        ax.scatter(pins[:, 0], pins[:, 1], pins[:, 2], s=60, c="black", depthshade=False, label="pins")
        ax.legend(loc="upper left")

    zmax = max(float(hi[2]), floor_z + 0.1)
    ax.set_xlim(fx0, fx1)
    ax.set_ylim(fy0, fy1)
    ax.set_zlim(floor_z, zmax)
    ax.set_box_aspect((fx1 - fx0, fy1 - fy0, zmax - floor_z), zoom=0.9)  # room for the z label
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(5))  # fewer ticks: the default ones run into each other
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)", labelpad=2)
    ax.view_init(elev=20, azim=-60)
    ax.set_title("%s - %s" % (title, time_label))
    out_dir = os.path.dirname(os.path.abspath(args.out))
    os.makedirs(out_dir, exist_ok=True)
    fig.savefig(args.out, dpi=args.dpi, bbox_inches="tight")
    plt.close(fig)
    print("wrote %s (%d triangles, frame '%s')" % (args.out, len(tris), marker.header.frame_id))
    return 0


if __name__ == "__main__":
    sys.exit(main())
