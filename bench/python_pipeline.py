#!/usr/bin/env python3
"""`omnisim dataset` against what a user would write instead: a Python pipeline.

The pipeline writes the same files for the same poses and the same rays: Open3D's
RaycastingScene.cast_rays (Embree 4, all cores) on omnisim's own ray map (raymap-origin.exr,
raymap-direction.exr), flat face colours, then per frame a colour PNG and a range EXR with
cv2.imwrite (EXR compressed as the spec's exr_compression asks of omnisim) and an Open3D
write_point_cloud binary PLY of the hit points with their colours. Poses are those omnisim's
data set recorded (.frames/*.json: position and world-from-body quaternion).

omnisim's rate is its own summary line ("... (N frames/s) ..."): frames rendered and written,
each file hashed (SHA-256) and fsynced, entries and manifest. The pipeline's rate is frames
over the loop's wall time; --fsync makes it fsync each file too (omnisim's durability).
Rounds alternate the two (and --baseline, another omnisim build, where given); each side's
best round is kept, and with --baseline the median of the rounds' omnisim / baseline ratios
(builds compare by those pairs, not by best rounds). Before each side's round the file system
is synced (`os.sync`, not timed):
otherwise the pipeline's unsynced 100 MB would be written back during the next omnisim round,
whose batch syncs (`syncfs`) wait for them. Prints JSON lines and a summary.

Usage: python_pipeline.py --omnisim BIN --spec SPEC --work DIR [--rounds 3] [--fsync] [--baseline BIN]
From the repository root, e.g. with the reader venv:
  target/readers-venv/bin/python bench/python_pipeline.py --omnisim target/release/omnisim \\
      --spec scenes/env1-speed-dataset.ron --work /tmp/pipeline
Needs open3d-cpu, numpy, OpenEXR, opencv-python (tests/readers/requirements.txt has them).
"""
import argparse, glob, json, os, re, shutil, statistics, subprocess, time

os.environ.setdefault('OPENCV_IO_ENABLE_OPENEXR', '1')
import cv2  # noqa: E402
import numpy as np  # noqa: E402
import open3d as o3d  # noqa: E402
import OpenEXR  # noqa: E402


def omnisim_dataset(omnisim, spec, out):
    """Runs the data set; returns omnisim's frames/s and the set folders it wrote."""
    shutil.rmtree(out, ignore_errors=True)
    os.sync()
    p = subprocess.run([omnisim, 'dataset', spec, '--out', out, '--backend', 'cpu'],
                       check=True, capture_output=True, text=True)
    rate = re.search(r'\(([0-9.]+) frames/s\)', p.stdout + p.stderr)
    if not rate:
        raise SystemExit(f'no "frames/s" in omnisim dataset output:\n{p.stdout}{p.stderr}')
    return float(rate.group(1)), sorted(d for d in glob.glob(os.path.join(out, '*')) if os.path.isdir(d))


def read_xyz(path):
    ch = OpenEXR.File(path, separate_channels=True).channels()
    return np.stack([ch[k].pixels for k in 'RGB'], -1).astype(np.float64)


def rotation(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def load_inputs(omnisim, spec, set_dir, work):
    """Scene triangles and colours, body-frame rays (pixels with a ray), image size, poses."""
    scene = os.path.join(os.path.dirname(os.path.abspath(spec)),
                         re.search(r'scene:\s*"([^"]+)"', open(spec).read()).group(1))
    ply = os.path.join(work, 'scene.ply')
    subprocess.run([omnisim, 'scene', 'export', scene, ply], check=True, capture_output=True)
    mesh = o3d.io.read_triangle_mesh(ply)
    v, t = np.asarray(mesh.vertices, np.float32), np.asarray(mesh.triangles, np.uint32)
    colours = (np.asarray(mesh.vertex_colors)[t[:, 0]] * 255).round().astype(np.uint8)
    origin = read_xyz(os.path.join(set_dir, 'raymap-origin.exr'))
    direction = read_xyz(os.path.join(set_dir, 'raymap-direction.exr'))
    height, width = direction.shape[:2]
    origin, direction = origin.reshape(-1, 3), direction.reshape(-1, 3)
    has_ray = np.isfinite(direction).all(1)
    poses = []
    for entry in sorted(glob.glob(os.path.join(set_dir, '.frames', '*.json'))):
        js = json.load(open(entry))
        if 'stem' not in js:  # not a frame entry
            continue
        poses.append((js['stem'], np.array(js['pose']['position']), rotation(js['pose']['quaternion_xyzw'])))
    return v, t, colours, origin, direction, has_ray, (width, height), poses


def write_durably(path, write):
    write(path)
    if FSYNC:
        fd = os.open(path, os.O_RDONLY)
        os.fsync(fd)
        os.close(fd)


def exr_compression(spec):
    """cv2's EXR compression for the spec's `exr_compression` (ZIP where it names none)."""
    named = re.search(r'exr_compression:\s*(\w+)', open(spec).read())
    return {'None': cv2.IMWRITE_EXR_COMPRESSION_NO, 'Rle': cv2.IMWRITE_EXR_COMPRESSION_RLE,
            'Zip': cv2.IMWRITE_EXR_COMPRESSION_ZIP}[named.group(1) if named else 'Zip']


def pipeline(inputs, out, compression):
    """The Python pipeline over every pose; returns frames/s."""
    v, t, colours, origin, direction, has_ray, (width, height), poses = inputs
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    os.sync()
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(t))
    o_body, d_body = origin[has_ray], direction[has_ray]
    exr_params = [cv2.IMWRITE_EXR_TYPE, cv2.IMWRITE_EXR_TYPE_FLOAT,
                  cv2.IMWRITE_EXR_COMPRESSION, compression]
    start = time.perf_counter()
    for stem, position, world_from_body in poses:
        o = o_body @ world_from_body.T + position
        d = d_body @ world_from_body.T
        hit = scene.cast_rays(o3d.core.Tensor(np.hstack([o, d]).astype(np.float32)))
        t_hit, ids = hit['t_hit'].numpy(), hit['primitive_ids'].numpy()
        hits = np.isfinite(t_hit)
        range_image = np.full(width * height, np.inf, np.float32)
        range_image[has_ray] = t_hit
        colour = np.zeros((width * height, 3), np.uint8)
        ray_colour = np.zeros((len(t_hit), 3), np.uint8)
        ray_colour[hits] = colours[ids[hits]]
        colour[has_ray] = ray_colour
        base = os.path.join(out, stem)
        write_durably(base + '.png', lambda p: cv2.imwrite(p, colour.reshape(height, width, 3)[:, :, ::-1]))
        write_durably(base + '-range.exr', lambda p: cv2.imwrite(p, range_image.reshape(height, width), exr_params))
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(o[hits] + t_hit[hits, None] * d[hits]))
        cloud.colors = o3d.utility.Vector3dVector(ray_colour[hits] / 255.0)
        write_durably(base + '.ply', lambda p: o3d.io.write_point_cloud(p, cloud, write_ascii=False))
    return len(poses) / (time.perf_counter() - start)


def main():
    global FSYNC
    ap = argparse.ArgumentParser()
    ap.add_argument('--omnisim', required=True)
    ap.add_argument('--spec', required=True)
    ap.add_argument('--work', required=True)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--fsync', action='store_true', help='fsync every file the pipeline writes')
    ap.add_argument('--baseline', help='another omnisim binary, run in each round after --omnisim')
    a = ap.parse_args()
    FSYNC = a.fsync
    os.makedirs(a.work, exist_ok=True)
    omnisim_out = os.path.join(a.work, 'omnisim')
    _, sets = omnisim_dataset(a.omnisim, a.spec, omnisim_out)
    inputs = load_inputs(a.omnisim, a.spec, sets[0], a.work)
    compression = exr_compression(a.spec)
    best_python = best_omnisim = best_baseline = 0.0
    omnisim_over_baseline = []
    for round_ in range(a.rounds):
        python = pipeline(inputs, os.path.join(a.work, 'python'), compression)
        omnisim, _ = omnisim_dataset(a.omnisim, a.spec, omnisim_out)
        baseline = omnisim_dataset(a.baseline, a.spec, omnisim_out)[0] if a.baseline else None
        best_python, best_omnisim = max(best_python, python), max(best_omnisim, omnisim)
        best_baseline = max(best_baseline, baseline or 0.0)
        if baseline:
            omnisim_over_baseline.append(omnisim / baseline)
        print(json.dumps(dict(round=round_, python_frames_per_s=python, omnisim_frames_per_s=omnisim,
                              baseline_frames_per_s=baseline, fsync=a.fsync, frames=len(inputs[-1]))), flush=True)
    print(f'best of {a.rounds}: python {best_python:.1f} frames/s, omnisim {best_omnisim:.1f} frames/s, '
          f'ratio {best_omnisim / best_python:.2f}x ({len(inputs[-1])} frames, python fsync: {a.fsync})')
    if a.baseline:
        print(f'baseline {best_baseline:.1f} frames/s, ratio {best_baseline / best_python:.2f}x')
        # A build against a build by the rounds' pairs: one lucky round moves a best-of figure by
        # 10-30 % on a loaded machine (docs/benchmarks.md, 2026-11-26 data, third turn).
        ahead = sum(r > 1 for r in omnisim_over_baseline)
        print(f'omnisim / baseline per round: median {statistics.median(omnisim_over_baseline):.2f}, '
              f'omnisim ahead in {ahead} of {len(omnisim_over_baseline)} rounds')


FSYNC = False

if __name__ == '__main__':
    main()
