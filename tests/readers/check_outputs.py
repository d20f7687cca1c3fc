"""Reads omnisim render folders with the readers people use and checks the values.
Lens cameras' points must land on their pixels through every calibration file the lens writes
(lens_projections: OpenCV projectPoints, fisheye, omnidir; Kalibr; OCamCalib's world2cam).

Usage: python3 tests/readers/check_outputs.py DIR  (every folder under DIR with a render.json)

OpenCV (EXR, FileStorage, cv2.omnidir.projectPoints), imageio (EXR, through its opencv
plugin), OpenEXR (headers, and every EXR again), python-plyfile (point clouds), PyYAML (Kalibr
camchains, as Kalibr reads them) and evo_traj (poses.txt). Every EXR must read the same, bit
for bit, in all three. Pixels are checked against the point clouds: a PLY lists the hit pixels
in row order, the pixels where the range EXR is finite, so every point has a known pixel centre
that each calibration file must project it to within 0.01 px, and the ray maps must rebuild it
from range. Versions: requirements.txt.
"""

import json
import os
import pathlib
import subprocess
import sys

os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"  # before cv2 is imported

import cv2  # noqa: E402
import imageio.v3 as iio  # noqa: E402
from imageio import __version__ as iio_version  # noqa: E402
import numpy as np  # noqa: E402
import OpenEXR  # noqa: E402
import plyfile  # noqa: E402
import yaml  # noqa: E402

PIXEL_TOLERANCE = 0.01
checks = 0
read = {"normal maps": 0, "ray maps": 0}


def check(condition, message):
    global checks
    if not condition:
        raise AssertionError(message)
    checks += 1


def same_bits(a, b):
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


def read_exr(path, quantity, channels):
    """The EXR as OpenCV and imageio read it, checked bit for bit against OpenEXR's reading of
    `channels` ("Y", or "RGB"), with its `quantity` header attribute."""
    exr = OpenEXR.File(str(path), separate_channels=True)  # else R, G, B come as one "RGB"
    header = exr.header()
    check(header.get("quantity") == quantity, f"{path}: quantity {header.get('quantity')!r}")
    check(sorted(exr.channels()) == sorted(channels), f"{path}: channels {sorted(exr.channels())}")
    stored = np.stack([exr.channels()[c].pixels for c in channels], axis=-1)
    if channels == "Y":
        stored = stored[..., 0]
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    check(image is not None, f"OpenCV cannot read {path}")
    if channels == "RGB":
        image = image[..., ::-1]  # OpenCV's order is B, G, R
    check(image.dtype == np.float32, f"{path}: OpenCV reads {image.dtype}")
    check(same_bits(image, stored), f"{path}: OpenCV values differ from OpenEXR's")
    # imageio's opencv plugin (its default for .exr) returns R, G, B; without these flags, 8 bits.
    other = iio.imread(str(path), plugin="opencv", flags=cv2.IMREAD_UNCHANGED)
    check(same_bits(other, stored), f"{path}: imageio values differ from OpenEXR's")
    return image, header


def read_value_exr(path, quantity):
    """A single-channel EXR (Y), read by OpenCV, imageio and OpenEXR."""
    image, header = read_exr(path, quantity, "Y")
    check("metres" in header.get("comments", "") or quantity == "disparity", f"{path}: comments")
    return image


def read_ray_map(folder, view):
    """A view's ray map: origins (metres) and unit directions, body frame, NaN where no ray."""
    origin, _ = read_exr(folder / f"raymap{view}-origin.exr", "ray origin", "RGB")
    direction, header = read_exr(folder / f"raymap{view}-direction.exr", "ray direction", "RGB")
    check("body frame" in header.get("comments", ""), f"{folder}: ray map comments")
    # Both again in one six-channel file, for OpenEXR-based tools: read as ../shared/bench's
    # same_rays.py reads it (the first raymap* file of the folder by name), bit for bit the same.
    both = OpenEXR.File(str(folder / f"raymap{view}-all.exr")).channels()
    first = sorted(p.name for p in folder.iterdir() if p.name.startswith(f"raymap{view}"))[0]
    check(first == f"raymap{view}-all.exr", f"{folder}: the first ray map by name is {first}")
    for name, values in (("origin", origin), ("direction", direction)):
        stored = np.stack([both[f"{name}.{k}"].pixels for k in "XYZ"], axis=-1)
        check(same_bits(stored, np.ascontiguousarray(values)), f"{folder}{view}: raymap-all's {name} differs")
    rays = np.isfinite(direction).all(axis=-1)
    check(rays.any() and np.array_equal(rays, np.isfinite(origin).all(axis=-1)), f"{folder}{view}: ray pixels")
    check(np.isnan(direction[~rays]).all(), f"{folder}{view}: pixels without a ray are NaN")
    length = np.linalg.norm(direction[rays].astype(np.float64), axis=-1)
    check(np.abs(length - 1).max() < 1e-6, f"{folder}{view}: directions off unit by {np.abs(length - 1).max():.1e}")
    read["ray maps"] += 1
    return origin.astype(np.float64), direction.astype(np.float64)


def check_normals(path, hit, points, origins):
    """Normals: unit where a pixel hits, NaN elsewhere, facing the ray they were seen along."""
    image, _ = read_exr(path, "normal", "RGB")
    normals = image[hit].astype(np.float64)
    check(np.isnan(image[~hit]).all(), f"{path}: pixels that hit nothing are NaN")
    length = np.linalg.norm(normals, axis=-1)
    check(np.abs(length - 1).max() < 1e-6, f"{path}: normals off unit by {np.abs(length - 1).max():.1e}")
    facing = np.einsum("ij,ij->i", normals, points - origins)
    check((facing < 0).all(), f"{path}: {np.count_nonzero(facing >= 0)} normals face away from the camera")
    read["normal maps"] += 1


def read_cloud(path):
    vertex = plyfile.PlyData.read(str(path))["vertex"]
    return np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=-1).astype(np.float64)


def storage(path):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    check(fs.isOpened(), f"FileStorage cannot open {path}")
    return fs


def matrix(fs, name):
    value = fs.getNode(name).mat()
    check(value is not None, f"no matrix {name}")
    return value


def close(projected, pixels, what):
    error = np.abs(projected.reshape(-1, 2) - pixels).max()
    check(error < PIXEL_TOLERANCE, f"{what}: pixels off by up to {error:.4f} px")


def pinhole_pixels(points_camera, k, d):
    projected, _ = cv2.projectPoints(points_camera.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    return projected


def check_view(folder, frame, suffix, rotation, position, raymap):
    """One image of one pose: range (OpenCV = OpenEXR), rays + range rebuild the PLY points."""
    stem = folder / f"{frame['stem']}{suffix}"
    rng = read_value_exr(f"{stem}-range.exr", "range")
    points = read_cloud(f"{stem}.ply")
    rows, cols = np.nonzero(np.isfinite(rng))
    check(len(rows) == len(points) > 0, f"{stem}: {len(points)} points for {len(rows)} hit pixels")
    origin, direction = raymap
    body = origin[rows, cols] + rng[rows, cols, None].astype(np.float64) * direction[rows, cols]
    rebuilt = body @ rotation.T + position
    error = np.linalg.norm(rebuilt - points, axis=1) / (1 + rng[rows, cols])
    check(error.max() < 1e-5, f"{stem}: range and ray map miss the PLY points by {error.max():.2e}")
    if f"{frame['stem']}{suffix}-normal.exr" in frame["files"]:
        origins = origin[rows, cols] @ rotation.T + position
        check_normals(f"{stem}-normal.exr", np.isfinite(rng), points, origins)
    return points, np.stack([cols, rows], axis=-1).astype(np.float64)


def check_folder(folder):
    meta = json.loads((folder / "render.json").read_text())
    camera = meta["camera"]
    model = camera["model"]
    views = ["-left", "-right"] if model == "stereo" else [""]
    result = subprocess.run([str(pathlib.Path(sys.executable).parent / "evo_traj"), "tum", str(folder / "poses.txt")],
                            capture_output=True, text=True)
    check(result.returncode == 0, f"evo_traj tum {folder}/poses.txt: {result.stderr}")
    raymaps = {v: read_ray_map(folder, v) for v in views}
    for frame in meta["frames"]:
        world_from_body = np.array(frame["world_from_body"])
        rotation, position = world_from_body[:3, :3], world_from_body[:3, 3]
        seen = {v: check_view(folder, frame, v, rotation, position, raymaps[v]) for v in views}
        body = {v: (points - position) @ rotation for v, (points, _) in seen.items()}
        stereo_lens = model == "stereo" and "lens" in camera["left"]
        if model == "pinhole" or (model == "stereo" and not stereo_lens):
            check_pinholes(folder, frame, seen, body)
        if stereo_lens:
            check_lens_stereo(folder, frame, camera, seen, body, raymaps)
        if "lens" in camera:
            points, pixels = seen[""]
            rays = np.isfinite(raymaps[""][1]).all(axis=-1)
            check(camera["pixels_without_ray"] == int((~rays).sum()),
                  f"{folder.name}: render.json's pixels_without_ray is the ray map's NaN count")
            readers = lens_projections(folder, body[""])
            check(readers or camera["lens"] in ("equisolid", "stereographic", "orthographic"),
                  f"{folder.name}: a {camera['lens']} lens writes calibration files")
            for name, projected, use in readers:
                close(projected, pixels[use], f"{folder.name} {name}")
            if f"{frame['stem']}-depth.exr" in frame["files"]:  # a distorted pinhole: z-depth
                fs = storage(folder / "calibration-opencv.yaml")
                z = opencv_optical(fs, body[""])[:, 2]
                depth = read_value_exr(folder / f"{frame['stem']}-depth.exr", "z")
                rows, cols = pixels[:, 1].astype(int), pixels[:, 0].astype(int)
                error = np.abs(depth[rows, cols] - z) / z
                check(error.max() < 1e-5, f"{folder.name}: depth off by {error.max():.2e}")
        elif (folder / "calibration-opencv-omnidir.yaml").exists():
            check_omni(folder, seen[""], body[""])
        print(f"{folder.name} {frame['stem']}: OK ({sum(len(p) for p, _ in seen.values())} points)")


# Kalibr's camera-config loader rules (kalibr_common/ConfigReader.py, CameraParameters:
# checkIntrinsics, checkDistortion, checkResolution): a camchain that breaks one does not load.
KALIBR_INTRINSICS = {"pinhole": 4, "omni": 5, "ds": 6, "eucm": 6}
KALIBR_DISTORTION = {"none": 0, "radtan": 4, "equidistant": 4, "fov": 1}


def kalibr_loader_rules(cam, where):
    model = cam["camera_model"]
    check(model in KALIBR_INTRINSICS, f"{where}: camera_model {model!r} is not one of Kalibr's")
    intrinsics = [float(v) for v in cam["intrinsics"]]
    check(len(intrinsics) == KALIBR_INTRINSICS[model], f"{where}: {model} takes {KALIBR_INTRINSICS[model]} intrinsics")
    fu, fv, pu, pv = intrinsics[-4:]
    check(fu > 0 and fv > 0, f"{where}: invalid focalLength {fu}, {fv}")
    check(pu > 0 and pv > 0, f"{where}: invalid principalPoint {pu}, {pv}")
    if model == "omni":
        check(intrinsics[0] >= 0, f"{where}: invalid xi")
    if model in ("ds", "eucm"):
        alpha = intrinsics[1] if model == "ds" else intrinsics[0]
        check(0 <= alpha <= 1, f"{where}: invalid alpha")
    distortion = cam["distortion_model"]
    check(distortion in KALIBR_DISTORTION, f"{where}: distortion_model {distortion!r} is not one of Kalibr's")
    check(len(cam["distortion_coeffs"]) == KALIBR_DISTORTION[distortion], f"{where}: {distortion} coefficients")
    resolution = cam["resolution"]
    check(len(resolution) == 2 and all(isinstance(v, int) and v > 0 for v in resolution), f"{where}: resolution")
    transform = np.array(cam["T_cam_imu"], dtype=np.float64)
    check(transform.shape == (4, 4) and abs(np.linalg.det(transform[:3, :3]) - 1) < 1e-12,
          f"{where}: T_cam_imu is not a rigid transform")


def read_kalibr(folder):
    """The camchain, each camera checked with Kalibr's loader rules."""
    chain = yaml.safe_load((folder / "calibration-kalibr.yaml").read_text())
    for name, cam in chain.items():
        kalibr_loader_rules(cam, f"{folder.name} {name}")
    return chain


def opencv_optical(fs, body):
    """Body points in the file's optical frame: X = body_from_camera^T (b - position)."""
    return (body - matrix(fs, "camera_position_in_body").ravel()) @ matrix(fs, "body_from_camera")


def kalibr_project(cam, body):
    """Kalibr's models (pinhole, omni, ds, eucm; none, radtan, equidistant) as aslam_cameras has them."""
    t = np.array(cam["T_cam_imu"], dtype=np.float64)
    x = body @ t[:3, :3].T + t[:3, 3]
    intrinsics = np.array(cam["intrinsics"], dtype=np.float64)
    model, (fu, fv, pu, pv) = cam["camera_model"], intrinsics[-4:]
    norm = np.linalg.norm(x, axis=1)
    if model == "pinhole":
        denominator = x[:, 2]
    elif model == "omni":
        denominator = x[:, 2] + intrinsics[0] * norm
    elif model == "ds":
        xi, alpha = intrinsics[:2]
        d2 = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2 + (xi * norm + x[:, 2]) ** 2)
        denominator = alpha * d2 + (1 - alpha) * (xi * norm + x[:, 2])
    else:  # eucm
        alpha, beta = intrinsics[:2]
        d = np.sqrt(beta * (x[:, 0] ** 2 + x[:, 1] ** 2) + x[:, 2] ** 2)
        denominator = alpha * d + (1 - alpha) * x[:, 2]
    m = x[:, :2] / denominator[:, None]
    k = np.array(cam["distortion_coeffs"], dtype=np.float64)
    if cam["distortion_model"] == "radtan":
        r2 = (m ** 2).sum(axis=1)
        radial = 1 + k[0] * r2 + k[1] * r2 ** 2
        mx, my = m[:, 0], m[:, 1]
        m = np.stack([mx * radial + 2 * k[2] * mx * my + k[3] * (r2 + 2 * mx ** 2),
                      my * radial + k[2] * (r2 + 2 * my ** 2) + 2 * k[3] * mx * my], axis=1)
    elif cam["distortion_model"] == "equidistant":
        r = np.linalg.norm(m, axis=1)
        theta = np.arctan(r)
        t2 = theta ** 2
        theta_d = theta * (1 + k[0] * t2 + k[1] * t2 ** 2 + k[2] * t2 ** 3 + k[3] * t2 ** 4)
        m = m * (theta_d / r)[:, None]
    return np.stack([fu * m[:, 0] + pu, fv * m[:, 1] + pv], axis=1)


# Basalt's loader (basalt-headers, headers_serialization.h): cereal reads these keys of
# "value0" in this order, and each camera_type's intrinsics by these names; a camera_type it
# does not know silently becomes its first variant (eucm), so an unknown one is refused here.
BASALT_KEYS = ["T_imu_cam", "intrinsics", "resolution", "calib_accel_bias", "calib_gyro_bias", "imu_update_rate",
               "accel_noise_std", "gyro_noise_std", "accel_bias_std", "gyro_bias_std", "cam_time_offset_ns",
               "vignette"]
BASALT_INTRINSICS = {"kb4": ["k1", "k2", "k3", "k4"], "ds": ["xi", "alpha"], "eucm": ["alpha", "beta"],
                     "ucm": ["alpha"], "pinhole": []}


def read_basalt(path):
    """Basalt's calibration JSON, checked with its loader's rules: keys and their order, camera
    types, intrinsic names, unit quaternions, one resolution per camera, IMU vector lengths."""
    root = json.loads(path.read_text())
    check(list(root) == ["value0"], f"{path}: cereal's root value0")
    calib = root["value0"]
    check(list(calib) == BASALT_KEYS, f"{path}: keys {list(calib)}")
    cameras = len(calib["intrinsics"])
    check(len(calib["T_imu_cam"]) == len(calib["resolution"]) == cameras > 0, f"{path}: one pose, size per camera")
    for entry in calib["intrinsics"]:
        kind = entry["camera_type"]
        check(kind in BASALT_INTRINSICS, f"{path}: camera_type {kind!r} is not one of Basalt's")
        check(list(entry["intrinsics"]) == ["fx", "fy", "cx", "cy"] + BASALT_INTRINSICS[kind], f"{path}: {kind} names")
    for pose in calib["T_imu_cam"]:
        check(list(pose) == ["px", "py", "pz", "qx", "qy", "qz", "qw"], f"{path}: T_imu_cam names")
        q = np.array([pose[k] for k in ("qx", "qy", "qz", "qw")])
        check(abs(np.linalg.norm(q) - 1) < 1e-12, f"{path}: T_imu_cam quaternion not unit")
    check(len(calib["calib_accel_bias"]) == 9 and len(calib["calib_gyro_bias"]) == 12, f"{path}: IMU bias lengths")
    check(all(len(calib[k]) == 3 for k in BASALT_KEYS[6:10]), f"{path}: IMU noise lengths")
    return calib


def basalt_project(calib, index, body):
    """Body points through Basalt's camera `index`: T_imu_cam's inverse, then its model as
    basalt-headers writes it (kb4, ds, eucm, ucm, pinhole)."""
    pose, entry = calib["T_imu_cam"][index], calib["intrinsics"][index]
    x_, y_, z_, w_ = (pose[k] for k in ("qx", "qy", "qz", "qw"))
    rotation = np.array([[1 - 2 * (y_ * y_ + z_ * z_), 2 * (x_ * y_ - z_ * w_), 2 * (x_ * z_ + y_ * w_)],
                         [2 * (x_ * y_ + z_ * w_), 1 - 2 * (x_ * x_ + z_ * z_), 2 * (y_ * z_ - x_ * w_)],
                         [2 * (x_ * z_ - y_ * w_), 2 * (y_ * z_ + x_ * w_), 1 - 2 * (x_ * x_ + y_ * y_)]])
    x = (body - np.array([pose["px"], pose["py"], pose["pz"]])) @ rotation
    i = entry["intrinsics"]
    kind = entry["camera_type"]
    norm = np.linalg.norm(x, axis=1)
    if kind == "kb4":
        r = np.hypot(x[:, 0], x[:, 1])
        theta = np.arctan2(r, x[:, 2])
        t2 = theta ** 2
        d = theta * (1 + i["k1"] * t2 + i["k2"] * t2 ** 2 + i["k3"] * t2 ** 3 + i["k4"] * t2 ** 4)
        m = x[:, :2] * (d / r)[:, None]
    else:
        if kind == "ds":
            d2 = np.sqrt(x[:, 0] ** 2 + x[:, 1] ** 2 + (i["xi"] * norm + x[:, 2]) ** 2)
            denominator = i["alpha"] * d2 + (1 - i["alpha"]) * (i["xi"] * norm + x[:, 2])
        elif kind == "eucm":
            d = np.sqrt(i["beta"] * (x[:, 0] ** 2 + x[:, 1] ** 2) + x[:, 2] ** 2)
            denominator = i["alpha"] * d + (1 - i["alpha"]) * x[:, 2]
        elif kind == "ucm":
            denominator = i["alpha"] * norm + (1 - i["alpha"]) * x[:, 2]
        else:
            denominator = x[:, 2]
        m = x[:, :2] / denominator[:, None]
    return np.stack([i["fx"] * m[:, 0] + i["cx"], i["fy"] * m[:, 1] + i["cy"]], axis=1)


def read_ocam(path):
    """OCamCalib's get_ocam_model: one comment line before each block, fixed order."""
    blocks = [line.split() for line in path.read_text().splitlines() if line.strip() and not line.startswith("#")]
    pol = [float(v) for v in blocks[0][1:1 + int(blocks[0][0])]]
    invpol = [float(v) for v in blocks[1][1:1 + int(blocks[1][0])]]
    xc, yc = (float(v) for v in blocks[2])
    c, d, e = (float(v) for v in blocks[3])
    height, width = (int(v) for v in blocks[4])
    stated = float(path.read_text().split("off by at most ")[1].split()[0])
    return dict(pol=pol, invpol=invpol, xc=xc, yc=yc, c=c, d=d, e=e, height=height, width=width, error=stated)


def cam2world(ocam, point2d):
    """ocam_functions.c cam2world: (row, column) -> unit vector of OCamCalib's frame."""
    invdet = 1 / (ocam["c"] - ocam["d"] * ocam["e"])
    xp = invdet * ((point2d[0] - ocam["xc"]) - ocam["d"] * (point2d[1] - ocam["yc"]))
    yp = invdet * (-ocam["e"] * (point2d[0] - ocam["xc"]) + ocam["c"] * (point2d[1] - ocam["yc"]))
    r = np.hypot(xp, yp)
    zp = sum(a * r ** i for i, a in enumerate(ocam["pol"]))
    v = np.array([xp, yp, zp])
    return v / np.linalg.norm(v)


def world2cam(ocam, point3d):
    """ocam_functions.c world2cam: OCamCalib frame -> (row, column)."""
    norm = np.hypot(point3d[0], point3d[1])
    theta = np.arctan(point3d[2] / norm)
    rho = sum(a * theta ** i for i, a in enumerate(ocam["invpol"]))
    x, y = point3d[0] / norm * rho, point3d[1] / norm * rho
    return np.array([x * ocam["c"] + y * ocam["d"] + ocam["xc"], x * ocam["e"] + y + ocam["yc"]])


def ocam_points(body):
    """Body points in OCamCalib's frame: omnisim's optical frame is (y, x, -z) of it."""
    optical = body @ np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], dtype=np.float64)
    return np.stack([optical[:, 1], optical[:, 0], -optical[:, 2]], axis=1)


def opencv_lens_file(folder, view=""):
    """A lens camera's OpenCV file and its kind ("", "-fisheye", "-omnidir"), or None."""
    for kind in ("", "-fisheye", "-omnidir"):
        path = folder / f"calibration-opencv{kind}{view}.yaml"
        if path.exists():
            return path, kind
    return None


def opencv_project(kind, k, d, xi, optical):
    """(reader, pixels (u, v), which points) of optical-frame points through OpenCV's module for
    `kind`: projectPoints, fisheye (points in front: it divides by z) or omnidir."""
    if kind == "-fisheye":
        front = optical[:, 2] > 0
        projected, _ = cv2.fisheye.projectPoints(optical[front].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
        return "cv2.fisheye.projectPoints", projected, front
    every = np.ones(len(optical), bool)
    if kind == "-omnidir":
        projected, _ = cv2.omnidir.projectPoints(optical.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, xi, d)
        return "cv2.omnidir.projectPoints", projected, every
    projected, _ = cv2.projectPoints(optical.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    return f"cv2.projectPoints ({d.size} coefficients)", projected, every


def kalibr_front(cam, x):
    """The points Kalibr's model projects: pinhole models divide by z, the others take all."""
    return x[:, 2] > 0 if cam["camera_model"] == "pinhole" else np.ones(len(x), bool)


def lens_projections(folder, body, view="", cam_name="cam0"):
    """(reader, pixels (u, v), which points) for every calibration file of a lens camera in
    `folder` (a stereo pair's `view`, "-left" or "-right", Kalibr's `cam_name`): OpenCV
    (projectPoints, fisheye, omnidir), Kalibr (loader rules checked first), OCamCalib's
    world2cam (within the error its file states: the tolerance is raised by it)."""
    found = []
    opencv = opencv_lens_file(folder, view)
    if opencv is not None:
        path, kind = opencv
        fs = storage(path)
        xi = fs.getNode("xi").real() if kind == "-omnidir" else None
        found.append(opencv_project(kind, matrix(fs, "camera_matrix"), matrix(fs, "distortion_coefficients"), xi,
                                    opencv_optical(fs, body)))
    if (folder / "calibration-kalibr.yaml").exists():
        cam = read_kalibr(folder)[cam_name]
        t = np.array(cam["T_cam_imu"], dtype=np.float64)
        use = kalibr_front(cam, body @ t[:3, :3].T + t[:3, 3])
        found.append((f"Kalibr {cam['camera_model']}-{cam['distortion_model']}", kalibr_project(cam, body[use]), use))
    if (folder / "calibration-basalt.json").exists():
        calib = read_basalt(folder / "calibration-basalt.json")
        index = int(cam_name[3:])
        found.append((f"Basalt {calib['intrinsics'][index]['camera_type']}", basalt_project(calib, index, body),
                      np.ones(len(body), bool)))
    if (folder / f"calib_results{view}.txt").exists():
        ocam = read_ocam(folder / f"calib_results{view}.txt")
        projected = np.array([world2cam(ocam, p)[::-1] for p in ocam_points(body)])
        found.append(("OCamCalib world2cam", projected, np.ones(len(body), bool)))
    return found


def check_lens_stereo(folder, frame, camera, seen, body, raymaps):
    """A stereo pair with a lens: no disparity; each camera's files put its points on its
    pixels; the right camera's points, placed by the left camera's OpenCV file and R, T (and
    by Kalibr's cam0 and T_cn_cnm1), land on the right image's pixels."""
    check(camera["disparity"].startswith("not written"), f"{folder.name}: render.json says why there is no disparity")
    check(not any(f.endswith("-disparity.exr") for f in frame["files"]), f"{folder.name}: no disparity file")
    lens = camera["left"]["lens"]
    for view, cam_name in (("-left", "cam0"), ("-right", "cam1")):
        rays = np.isfinite(raymaps[view][1]).all(axis=-1)
        check(camera[view[1:]]["pixels_without_ray"] == int((~rays).sum()),
              f"{folder.name}{view}: render.json's pixels_without_ray is the ray map's NaN count")
        readers = lens_projections(folder, body[view], view, cam_name)
        check(readers or lens in ("equisolid", "stereographic", "orthographic"),
              f"{folder.name}{view}: a {lens} lens writes calibration files")
        pixels = seen[view][1]
        for name, projected, use in readers:
            close(projected, pixels[use], f"{folder.name}{view} {name}")
        if f"{frame['stem']}{view}-depth.exr" in frame["files"]:  # distorted pinholes: z-depth
            z = opencv_optical(storage(folder / f"calibration-opencv{view}.yaml"), body[view])[:, 2]
            depth = read_value_exr(folder / f"{frame['stem']}{view}-depth.exr", "z")
            error = np.abs(depth[pixels[:, 1].astype(int), pixels[:, 0].astype(int)] - z) / z
            check(error.max() < 1e-5, f"{folder.name}{view}: depth off by {error.max():.2e}")
    pixels = seen["-right"][1]
    stereo = storage(folder / "calibration-opencv-stereo.yaml")
    r, t = matrix(stereo, "R"), matrix(stereo, "T")
    check(abs(np.linalg.det(r) - 1) < 1e-12 and abs(np.linalg.norm(t) - camera["baseline"]) < 1e-12,
          f"{folder.name}: R, T are a rigid motion by the baseline")
    left, right = opencv_lens_file(folder, "-left"), opencv_lens_file(folder, "-right")
    if left is not None:  # the stereo file places the left camera as its own file does
        for name in ("body_from_camera", "camera_position_in_body"):
            check(np.array_equal(matrix(stereo, name), matrix(storage(left[0]), name)), f"{folder.name}: {name}")
    optical = opencv_optical(stereo, body["-right"]) @ r.T + t.ravel()
    if right is not None:
        kind = right[1]
        for fs, k, d, xi in [
            (storage(right[0]), "camera_matrix", "distortion_coefficients", "xi"),
            (stereo, "M2", "D2", "xi2"),
        ]:
            xi_value = fs.getNode(xi).real() if kind == "-omnidir" else None
            name, projected, use = opencv_project(kind, matrix(fs, k), matrix(fs, d), xi_value, optical)
            close(projected, pixels[use], f"{folder.name} right through R, T and {k}: {name}")
    else:
        check(left is None and stereo.getNode("M2").empty(), f"{folder.name}: OpenCV files only where OpenCV has the lens")
    if (folder / "calibration-kalibr.yaml").exists():
        chain = read_kalibr(folder)
        check(set(chain) == {"cam0", "cam1"}, f"{folder.name}: the camchain has cam0 and cam1")
        t0, t1 = (np.array(chain[c]["T_cam_imu"], dtype=np.float64) for c in ("cam0", "cam1"))
        t10 = np.array(chain["cam1"]["T_cn_cnm1"], dtype=np.float64)
        check(t10.shape == (4, 4) and abs(np.linalg.det(t10[:3, :3]) - 1) < 1e-12
              and np.array_equal(t10[3], [0, 0, 0, 1]), f"{folder.name}: T_cn_cnm1 is a rigid transform")
        check(abs(np.linalg.norm(t10[:3, 3]) - camera["baseline"]) < 1e-12, f"{folder.name}: |T_cn_cnm1| = baseline")
        check(np.abs(t10 @ t0 - t1).max() < 1e-12, f"{folder.name}: T_cn_cnm1 T_cam0_imu = T_cam1_imu")
        x = body["-right"] @ t0[:3, :3].T + t0[:3, 3]
        x = x @ t10[:3, :3].T + t10[:3, 3]
        use = kalibr_front(chain["cam1"], x)
        close(kalibr_project(dict(chain["cam1"], T_cam_imu=np.eye(4)), x[use]), pixels[use],
              f"{folder.name} right through Kalibr cam0 and T_cn_cnm1")


def check_pinholes(folder, frame, seen, body):
    kalibr = read_kalibr(folder)
    if "-left" in seen:
        fs = storage(folder / "calibration-opencv-stereo.yaml")
        k = {"-left": matrix(fs, "M1"), "-right": matrix(fs, "M2")}
        d = {"-left": matrix(fs, "D1"), "-right": matrix(fs, "D2")}
        r, t = matrix(fs, "R"), matrix(fs, "T")
        baseline = fs.getNode("baseline").real()
        cameras = {"-left": "cam0", "-right": "cam1"}
    else:
        fs = storage(folder / "calibration-opencv.yaml")
        k, d = {"": matrix(fs, "camera_matrix")}, {"": matrix(fs, "distortion_coefficients")}
        cameras = {"": "cam0"}
    body_from_camera = matrix(fs, "body_from_camera")
    position = matrix(fs, "camera_position_in_body").ravel()
    for view, (points, pixels) in seen.items():
        # The OpenCV file places the (left) camera; the right one is X_right = R X_left + T.
        optical = (body[view] - position) @ body_from_camera
        if view == "-right":
            optical = optical @ r.T + t.ravel()
        close(pinhole_pixels(optical, k[view], d[view]), pixels, f"{folder.name} {view} OpenCV")
        close(kalibr_project(kalibr[cameras[view]], body[view]), pixels, f"{folder.name} {view} Kalibr")
        depth = read_value_exr(folder / f"{frame['stem']}{view}-depth.exr", "z")
        rows, cols = pixels[:, 1].astype(int), pixels[:, 0].astype(int)
        error = np.abs(depth[rows, cols] - optical[:, 2]) / optical[:, 2]
        check(error.max() < 1e-5, f"{folder.name}{view}: depth off by {error.max():.2e}")
    if "-left" in seen:
        disparity = read_value_exr(folder / f"{frame['stem']}-disparity.exr", "disparity")
        pixels = seen["-left"][1]
        rows, cols = pixels[:, 1].astype(int), pixels[:, 0].astype(int)
        optical = (body["-left"] - position) @ body_from_camera
        expected = k["-left"][0, 0] * baseline / optical[:, 2]
        error = np.abs(disparity[rows, cols] - expected) / expected
        check(error.max() < 1e-5, f"{folder.name}: disparity off by {error.max():.2e}")


def check_omni(folder, seen, body):
    points, pixels = seen
    fs = storage(folder / "calibration-opencv-omnidir.yaml")
    k, d = matrix(fs, "camera_matrix"), matrix(fs, "distortion_coefficients")
    xi = fs.getNode("xi").real()  # a real, as the file says
    check(0 < xi <= 1, f"xi = {xi}")
    mirror = body @ matrix(fs, "body_from_mirror")
    model = mirror * np.array([1.0, 1.0, -1.0])  # the file's model frame (a reflection)
    projected, _ = cv2.omnidir.projectPoints(model.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, xi, d)
    close(projected, pixels, f"{folder.name} cv2.omnidir")
    kalibr = read_kalibr(folder)
    # Kalibr's camera is the image flipped top to bottom (positive focal lengths; the file says so).
    check("IMAGE FLIPPED" in (folder / "calibration-kalibr.yaml").read_text(), "Kalibr omni says the image is flipped")
    height = kalibr["cam0"]["resolution"][1]
    flipped = pixels * np.array([1.0, -1.0]) + np.array([0.0, height - 1.0])
    close(kalibr_project(kalibr["cam0"], body), flipped, f"{folder.name} Kalibr omni")


def main():
    root = pathlib.Path(sys.argv[1])
    folders = sorted(p.parent for p in root.rglob("render.json"))
    if not folders:
        sys.exit(f"no render.json under {root}")
    for folder in folders:
        check_folder(folder)
    print(f"{checks} checks passed in {len(folders)} folders ({read['normal maps']} normal maps, "
          f"{read['ray maps']} ray maps) with OpenCV {cv2.__version__}, imageio {iio_version}, "
          f"OpenEXR {OpenEXR.__version__}, plyfile, PyYAML, evo")


if __name__ == "__main__":
    main()
