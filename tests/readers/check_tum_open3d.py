"""Open3D reads a TUM RGB-D folder omnisim wrote: every rgb.txt/depth.txt pair loads with
o3d.io.read_image and RGBDImage.create_from_tum_format. Prints one JSON line per pair with
Open3D's depth (metres) summarised, and its largest difference from the ground-truth depth EXR
read by OpenCV, for the Rust test (crates/omnisim/src/dataset/tests.rs) to check.

usage: check_tum_open3d.py TUM_DIR DEPTH_EXR...   (one EXR per pair, in rgb.txt order)
"""
import json
import os
import sys

os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2  # noqa: E402
import numpy as np  # noqa: E402
import open3d as o3d  # noqa: E402


def entries(path):
    with open(path) as f:
        return [line.split() for line in f if line.strip() and not line.startswith("#")]


tum, exrs = sys.argv[1], sys.argv[2:]
rgb, depth = entries(os.path.join(tum, "rgb.txt")), entries(os.path.join(tum, "depth.txt"))
assert len(rgb) == len(depth) == len(exrs), (len(rgb), len(depth), len(exrs))
for (t_rgb, rgb_file), (t_depth, depth_file), exr in zip(rgb, depth, exrs):
    colour = o3d.io.read_image(os.path.join(tum, rgb_file))
    depth_image = o3d.io.read_image(os.path.join(tum, depth_file))
    rgbd = o3d.geometry.RGBDImage.create_from_tum_format(colour, depth_image, convert_rgb_to_intensity=False)
    metres = np.asarray(rgbd.depth, dtype=np.float64)
    truth = cv2.imread(exr, cv2.IMREAD_UNCHANGED).astype(np.float64)
    # TUM PNGs hold z * 5000 in 16 bits, 0 = no hit or beyond 13.1 m.
    stored = np.isfinite(truth) & (truth * 5000 < 65535.5)
    upper = metres[: metres.shape[0] // 2]
    print(json.dumps({
        "timestamps": [float(t_rgb), float(t_depth)],
        "size": [metres.shape[1], metres.shape[0]],
        "colour_size": list(np.asarray(rgbd.color).shape),
        "upper_half_depth": [float(upper.min()), float(upper.max())],
        "max_error_vs_exr": float(np.abs(metres[stored] - truth[stored]).max()),
        "zero_where_no_depth": bool((metres[~stored] == 0).all()),
    }))
