"""Reads every .npy that `omnisim describe` wrote with numpy and checks it against its JSON
sidecar (shape, dtype, frame count, keypoint index); for crates/omnisim-cli/tests/vision.rs.

usage: python check_descriptors.py DESCRIBE_OUT_FOLDER REPORT.json
The report holds, per set and file, the shape and the first row's values as numpy read them,
for the Rust test to compare with what the library computes.
"""

import json
import sys
from pathlib import Path

import numpy as np

root = Path(sys.argv[1])
report = {}
failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


for sidecar_path in sorted(root.glob("*/*.json")):
    sidecar = json.loads(sidecar_path.read_text())
    folder = sidecar_path.parent
    name = sidecar["descriptor"]
    frames = len(sidecar["frames"])
    check(sidecar["dtype"] == "<f4", f"{sidecar_path}: dtype {sidecar['dtype']}")
    entry = report.setdefault(folder.name, {})
    for role, file in sidecar["files"].items():
        array = np.load(folder / file)
        check(array.dtype == np.dtype("<f4"), f"{file}: dtype {array.dtype}")
        check(np.isfinite(array).all(), f"{file}: values that are not finite")
        # An image set can give no keypoints at all: an empty array has no first row.
        first = array[0].ravel()[:256].astype(float).tolist() if len(array) else []
        entry[file] = {"shape": list(array.shape), "first": first}
        if role == "pca":
            check(array.shape == (frames, sidecar["pca"]["components"]), f"{file}: shape {array.shape}")
        elif role in ("keypoints", "descriptors"):
            check(list(array.shape) == sidecar["shape"][role], f"{file}: shape {array.shape} vs {sidecar['shape'][role]}")
        else:
            check(list(array.shape) == sidecar["shape"], f"{file}: shape {array.shape} vs {sidecar['shape']}")
            check(array.shape[0] == frames, f"{file}: {array.shape[0]} rows for {frames} frames")
        if role == "keypoints":
            image = array[:, 0]
            counts = np.bincount(image.astype(int), minlength=frames)
            check(counts.tolist() == sidecar["keypoints_per_image"], f"{file}: keypoints per image {counts.tolist()}")
            check((np.diff(image) >= 0).all(), f"{file}: image index not in frame order")
        if role == "descriptors":
            norms = np.linalg.norm(array, axis=1)
            check(np.allclose(norms, 1, atol=1e-4), f"{file}: descriptors not unit length")
            entry[file]["rows_of_first_image"] = int((np.load(folder / sidecar["files"]["keypoints"])[:, 0] == 0).sum())

for pca_folder in sorted((root / "pca").glob("*")):
    axes = np.load(pca_folder / "axes.npy")
    mean = np.load(pca_folder / "mean.npy")
    check(axes.shape[1] == mean.shape[0], f"{pca_folder}: axes {axes.shape} vs mean {mean.shape}")
    check(np.allclose(axes @ axes.T, np.eye(axes.shape[0]), atol=1e-4), f"{pca_folder}: axes not orthonormal")
    variances = np.load(pca_folder / "variances.npy")
    total = json.loads((pca_folder / "pca.json").read_text())["total_variance"]
    check(variances.shape == (axes.shape[0],), f"{pca_folder}: {variances.shape} variances for {axes.shape[0]} axes")
    check(variances.sum() <= total * (1 + 1e-5), f"{pca_folder}: variances add up to more than the total {total}")

(Path(sys.argv[2])).write_text(json.dumps(report))
if failures:
    sys.exit("\n".join(failures))
print(f"numpy {np.__version__}: read {sum(len(v) for v in report.values())} arrays")
