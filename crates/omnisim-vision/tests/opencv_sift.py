"""OpenCV's SIFT with its defaults on one image, for crates/omnisim-vision/tests/keypoints.rs.

usage: python opencv_sift.py IMAGE.png OUT_FOLDER
writes OUT_FOLDER/keypoints.npy (N x 5 float32: x, y, size, angle, response) and
OUT_FOLDER/descriptors.npy (N x 128 float32, OpenCV's scale: unit length x 512, rounded).
"""

import sys
from pathlib import Path

import cv2
import numpy as np

image = cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE)
if image is None:
    sys.exit(f"cannot read {sys.argv[1]}")
keypoints, descriptors = cv2.SIFT_create().detectAndCompute(image, None)
rows = np.array([[k.pt[0], k.pt[1], k.size, k.angle, k.response] for k in keypoints], dtype=np.float32)
out = Path(sys.argv[2])
np.save(out / "keypoints.npy", rows.reshape(-1, 5))
np.save(out / "descriptors.npy", np.asarray(descriptors, dtype=np.float32).reshape(-1, 128))
print(f"OpenCV {cv2.__version__}: {len(keypoints)} SIFT keypoints")
