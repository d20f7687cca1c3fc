#!/usr/bin/env python3
"""BVH build time against Open3D (Embree 4) on the same triangles, at several sizes.

Each scene is the room of raycast_anchor.py plus N/12 small rotated boxes (seeded), written as
a binary PLY. Open3D's build is `RaycastingScene.add_triangles` plus its first `cast_rays` of
one ray (Embree builds lazily, on the first query); omnisim's is the `bvh_build_ms` that
`omnisim bench` reports (obvhs's BVH2 and the 8-wide BVH collapsed from it). Best of
--rounds for each, rounds alternating the two. Also prints omnisim's peak resident memory
per triangle (the difference between the largest and the smallest scene, so the fixed cost
of the program drops out) and the bytes a triangle that the built BVH holds (`bvh_bytes`; nan from
binaries older than it).

Usage: bvh_build.py --omnisim BIN --work DIR [--sizes 10000,100000,300000,1000000] [--rounds 3]
Needs open3d-cpu and numpy (same_rays.sh's venv, or BENCH_PYTHON's).
"""
import argparse, json, os, subprocess, sys, time

import numpy as np
import open3d as o3d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import raycast_anchor as ra  # noqa: E402


def scene(work, triangles):
    """A room with clutter boxes making about `triangles` triangles: (PLY path, RON path)."""
    ply = os.path.join(work, f'build_{triangles}.ply')
    ron = os.path.join(work, f'build_{triangles}.ron')
    if not os.path.exists(ply):
        rng = np.random.default_rng(ra.SEED + triangles)
        room_v, room_t = ra._boxes(ra.CAM[None, :], ra.ROOM[None, :], inward=True)
        n = max(1, (triangles - len(room_t)) // 12)
        centres = rng.uniform([0.1, 0.1, 0.1], ra.ROOM - 0.1, size=(n, 3))
        sizes = rng.uniform(0.02, 0.08, size=(n, 3))
        box_v, box_t = ra._boxes(centres, sizes, ra._random_rotations(rng, n))
        v = np.vstack([room_v, box_v])
        t = np.vstack([room_t, box_t + len(room_v)])
        ra.write_ply(ply, v.astype(np.float32), t.astype(np.int32))
        with open(ron, 'w') as f:
            f.write(f'Scene(name: "build{triangles}", objects: [Mesh(name: "m", path: "{os.path.basename(ply)}", '
                    'colour: (200, 200, 200))])\n')
    return ply, ron


def open3d_build(v, t):
    start = time.perf_counter()
    sc = o3d.t.geometry.RaycastingScene()
    sc.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(t))
    sc.cast_rays(o3d.core.Tensor(np.array([[3, 2, 1.5, 1, 0, 0]], dtype=np.float32)))['t_hit'].numpy()
    return time.perf_counter() - start


def omnisim_build(binary, ron):
    p = subprocess.run([binary, 'bench', ron, '--camera', 'pinhole', '--size', '8x8', '--pose', '3,2,1.5',
                        '--backend', 'cpu', '--runs', '1', '--warmup', '0'], check=True, capture_output=True, text=True)
    js = json.loads(p.stdout.splitlines()[0])
    return js['bvh_build_ms'] / 1e3, js['peak_rss_mb'], js['triangles'], js.get('bvh_bytes')


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--omnisim', required=True)
    ap.add_argument('--work', required=True)
    ap.add_argument('--sizes', default='10000,100000,300000,1000000')
    ap.add_argument('--rounds', type=int, default=3)
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rows = []
    for size in [int(s) for s in a.sizes.split(',')]:
        ply, ron = scene(a.work, size)
        v, t = ra.read_ply(ply)
        best_o3d = best_om = float('inf')
        rss = triangles = None
        for _ in range(a.rounds):
            best_o3d = min(best_o3d, open3d_build(v, t))
            seconds, rss, triangles, bvh_bytes = omnisim_build(a.omnisim, ron)
            best_om = min(best_om, seconds)
        row = dict(triangles=triangles, open3d_ms=1e3 * best_o3d, omnisim_ms=1e3 * best_om,
                   ratio=best_o3d / best_om, omnisim_peak_rss_mb=rss,
                   omnisim_bvh_bytes_per_triangle=bvh_bytes / triangles if bvh_bytes else float('nan'))
        rows.append(row)
        print(json.dumps(row), flush=True)
    print(f"\n{'triangles':>10} {'open3d ms':>10} {'omnisim ms':>10} {'ratio':>6} {'peak MB':>8} {'BVH B/tri':>9}")
    for r in rows:
        print(f"{r['triangles']:10d} {r['open3d_ms']:10.1f} {r['omnisim_ms']:10.1f} {r['ratio']:5.2f}x "
              f"{r['omnisim_peak_rss_mb']:8.1f} {r['omnisim_bvh_bytes_per_triangle']:9.0f}")
    if len(rows) > 1:
        lo, hi = rows[0], rows[-1]
        per = (hi['omnisim_peak_rss_mb'] - lo['omnisim_peak_rss_mb']) * 1e6 / (hi['triangles'] - lo['triangles'])
        print(f"omnisim peak memory: {per:.0f} bytes per triangle (between {lo['triangles']} and {hi['triangles']})")


if __name__ == '__main__':
    main()
