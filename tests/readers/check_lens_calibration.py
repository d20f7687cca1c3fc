"""Reads the calibration files omnisim writes for lens cameras with the tools' own code and
checks they project the same points to omnisim's pixels.

Usage: python3 tests/readers/check_lens_calibration.py DIR  (one folder per lens, each with
points.txt: body-frame x y z and omnisim's u v in f64, and the lens's calibration files)

- calibration-opencv.yaml: cv2.projectPoints (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]);
- calibration-opencv-fisheye.yaml: cv2.fisheye.projectPoints (Kannala-Brandt; points in front);
- calibration-opencv-omnidir.yaml: cv2.omnidir.projectPoints (Mei's unified model + radtan);
- calibration-kalibr.yaml: Kalibr's loader rules, then its models (pinhole, omni, ds, eucm with
  none, radtan or equidistant distortion) written out from aslam_cameras;
- calibration-basalt.json: Basalt's loader rules (cereal's keys and order, camera types,
  intrinsic names), then its models (kb4, ds, eucm, ucm) written out from basalt-headers;
- calib_results.txt: read as OCamCalib's get_ocam_model reads it; its cam2world must give each
  pixel's ray exactly, its world2cam (the fitted inverse polynomial) the pixel within the error
  the file states.
OpenCV, Kalibr and Basalt must agree with omnisim within 1e-6 px.
"""

import pathlib
import sys

import cv2
import numpy as np

from check_outputs import cam2world, check, lens_projections, ocam_points, read_ocam

TOLERANCE = 1e-6


def agree(projected, pixels, what, tolerance):
    error = np.abs(np.asarray(projected, dtype=np.float64).reshape(-1, 2) - pixels).max()
    check(error <= tolerance, f"{what}: pixels off by up to {error:.3e} px")
    return error


def check_lens(folder):
    table = np.loadtxt(folder / "points.txt", dtype=np.float64)
    body, pixels = table[:, :3], table[:, 3:]
    read = []
    ocam = read_ocam(folder / "calib_results.txt") if (folder / "calib_results.txt").exists() else None
    for name, projected, use in lens_projections(folder, body):
        # OCamCalib's world2cam is a fitted polynomial: within the error its file states.
        tolerance = TOLERANCE + (ocam["error"] if name.startswith("OCamCalib") else 0.0)
        read.append(f"{name} {agree(projected, pixels[use], f'{folder.name} {name}', tolerance):.1e} px")
    if ocam is not None:
        check(ocam["error"] < 1e-3, f"{folder.name}: inverse polynomial off by {ocam['error']}")
        worst = 0.0
        for point, (u, v) in zip(ocam_points(body), pixels):
            worst = max(worst, np.linalg.norm(cam2world(ocam, (v, u)) - point / np.linalg.norm(point)))
        check(worst < 1e-9, f"{folder.name}: cam2world off by {worst:.2e}")
        read.append(f"OCamCalib cam2world {worst:.1e}")
    check(read, f"{folder.name}: no calibration file read")
    print(f"{folder.name} ({len(body)} points): " + "; ".join(read))


def main():
    folders = sorted(p for p in pathlib.Path(sys.argv[1]).iterdir() if (p / "points.txt").exists())
    for folder in folders:
        check_lens(folder)
    print(f"{len(folders)} lenses checked with OpenCV {cv2.__version__}, Kalibr's and Basalt's rules and OCamCalib's "
          "functions")


if __name__ == "__main__":
    main()
