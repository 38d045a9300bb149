#!/usr/bin/python3
"""Draws what a simulated depth camera sees: its depth image, its shaded colour image, and the point cloud
back-projected from the depth image (x = (u - cx) z / fx, y = (v - cy) z / fy, as depth_image_proc does),
seen from another angle.

    depth_camera_tool --scene drape --out DIR     # writes DIR/depth.f32, rgb.u8, mask.u8, camera.json
    scripts/camera_picture.py DIR doc/images/camera_drape.png

Needs numpy and matplotlib (python3-numpy, python3-matplotlib).
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

POINT_STRIDE = 3  # every third pixel each way: a readable scatter
# What depth_camera_tool --out DIR writes, all read here.
CAMERA_FILES = ("camera.json", "depth.f32", "rgb.u8")


def main(folder, output):
    with open(os.path.join(folder, "camera.json")) as f:
        camera = json.load(f)
    width, height = camera["width"], camera["height"]
    depth = np.fromfile(os.path.join(folder, "depth.f32"), dtype="<f4").reshape(height, width)
    rgb = np.fromfile(os.path.join(folder, "rgb.u8"), dtype=np.uint8).reshape(height, width, 3)

    figure = plt.figure(figsize=(15, 4.6))
    title = "%s scene, %dx%d cloth, t = %.1f s, %dx%d camera" % (
        camera["scene"], camera["rows"], camera["cols"], camera["time_s"], width, height)
    figure.suptitle(title)

    axis = figure.add_subplot(1, 3, 1)
    shown = axis.imshow(np.ma.masked_invalid(depth), cmap="viridis")
    axis.set_title("~N/depth/image_raw (32FC1; NaN white)")
    axis.set_xticks([])
    axis.set_yticks([])
    figure.colorbar(shown, ax=axis, fraction=0.046, pad=0.02, label="depth z [m]")

    axis = figure.add_subplot(1, 3, 2)
    axis.imshow(rgb)
    axis.set_title("~N/rgb/image_raw (shaded vertex colours)")
    axis.set_xticks([])
    axis.set_yticks([])

    v, u = np.mgrid[0:height:POINT_STRIDE, 0:width:POINT_STRIDE]
    z = depth[v, u]
    seen = np.isfinite(z)
    x = (u[seen] - camera["cx"]) * z[seen] / camera["fx"]
    y = (v[seen] - camera["cy"]) * z[seen] / camera["fy"]
    colors = rgb[v, u][seen] / 255.0
    # Back into the world frame (z up) with the camera's pose, so the cloth hangs as it does in rviz.
    pose = np.array(camera["world_from_optical"])
    world = pose[:, :3] @ np.stack([x, y, z[seen]]) + pose[:, 3:4]
    axis = figure.add_subplot(1, 3, 3, projection="3d")
    axis.scatter(world[0], world[1], world[2], c=colors, s=1.5, depthshade=False)
    axis.set_xlabel("x [m]")
    axis.set_ylabel("y [m]")
    axis.set_zlabel("z [m]")
    spans = world.max(axis=1) - world.min(axis=1)
    axis.set_box_aspect(spans / spans.max())
    axis.view_init(elev=15, azim=-60)
    axis.set_title("~N/depth/points in the world frame")
    figure.tight_layout()
    figure.savefig(output, dpi=90)
    print("wrote %s (%d points)" % (output, int(seen.sum())))


def parse_args(argv=None):
    """DIR and OUT.png, refused in one line (argparse's exit 2) where a file is missing: not a traceback."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     epilog="DIR is depth_camera_tool --out's folder")
    parser.add_argument("folder", metavar="DIR")
    parser.add_argument("output", metavar="OUT.png")
    args = parser.parse_args(argv)
    if not os.path.isdir(args.folder):
        parser.error("DIR %s: no such folder (the one depth_camera_tool --out DIR wrote into)" % args.folder)
    missing = [name for name in CAMERA_FILES if not os.path.isfile(os.path.join(args.folder, name))]
    if missing:
        parser.error("DIR %s: no %s in it (depth_camera_tool --out DIR writes them)" % (args.folder, ", ".join(missing)))
    out_folder = os.path.dirname(os.path.abspath(args.output))
    if not os.path.isdir(out_folder):
        parser.error("OUT.png %s: no folder %s" % (args.output, out_folder))
    return args


if __name__ == "__main__":
    arguments = parse_args()
    main(arguments.folder, arguments.output)
