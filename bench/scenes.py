#!/usr/bin/env python3
"""Generated test scenes of any size, for the same-rays and BVH-build benchmarks.

Scenes the tuning never saw: each kind is a 6 × 4 × 3 m room (raycast_anchor.ROOM) holding about
N triangles of one sort, seeded, so every size of every kind is reproducible.

  scan    a scanned-like room: walls, floor and ceiling as dense noisy height fields (a
          photogrammetry mesh of a room), plus a few scanned objects (noisy displaced spheres)
          standing on the floor; triangles of even size, mostly large flat areas.
  boxes   shelving: many small axis-aligned boxes on rows of shelves and stacked on the floor
          (a warehouse or a store), all clear of the room centre.
  clutter the room of raycast_anchor.py with N/12 small rotated boxes floating everywhere
          (bvh_build.py's scenes).

Usage: scenes.py KIND TRIANGLES OUT.ply  (or import: make(kind, triangles) -> (v, t)).
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import raycast_anchor as ra  # noqa: E402

KINDS = ('scan', 'boxes', 'clutter')


def _grid(nu, nv):
    """Triangles of an nu × nv vertex grid (row-major), two per cell."""
    i = np.arange(nu - 1)[:, None] * nv + np.arange(nv - 1)[None, :]
    i = i.reshape(-1)
    a, b, c, d = i, i + 1, i + nv, i + nv + 1
    return np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])


def _noise(rng, shape, scale):
    """Smooth-ish noise: a sum of a few random sine waves plus a little white noise."""
    u, v = np.meshgrid(np.linspace(0, 1, shape[0]), np.linspace(0, 1, shape[1]), indexing='ij')
    h = np.zeros(shape)
    for k in range(6):
        f = rng.uniform(2, 30, 2)
        h += np.sin(2 * np.pi * (f[0] * u + f[1] * v) + rng.uniform(0, 6.3)) / (k + 1)
    return scale * (h / 3 + 0.2 * rng.standard_normal(shape))


def _scan(rng, triangles):
    room = ra.ROOM
    # Six walls (floor, ceiling, four sides) share 80 % of the triangles by area; objects 20 %.
    faces = [  # origin, u axis, v axis (spanning the wall), inward normal
        ((0, 0, 0), (room[0], 0, 0), (0, room[1], 0), (0, 0, 1)),
        ((0, 0, room[2]), (0, room[1], 0), (room[0], 0, 0), (0, 0, -1)),
        ((0, 0, 0), (0, 0, room[2]), (room[0], 0, 0), (0, 1, 0)),
        ((0, room[1], 0), (room[0], 0, 0), (0, 0, room[2]), (0, -1, 0)),
        ((0, 0, 0), (0, room[1], 0), (0, 0, room[2]), (1, 0, 0)),
        ((room[0], 0, 0), (0, 0, room[2]), (0, room[1], 0), (-1, 0, 0)),
    ]
    areas = [np.linalg.norm(np.cross(u, v)) for _, u, v, _ in faces]
    wall_budget = 0.8 * triangles
    verts, tris, off = [], [], 0
    for (o, u, v, n), area in zip(faces, areas):
        cells = wall_budget * area / sum(areas) / 2
        lu, lv = np.linalg.norm(u), np.linalg.norm(v)
        nu = max(2, int(round(np.sqrt(cells * lu / lv))) + 1)
        nv = max(2, int(round(cells / (nu - 1))) + 1)
        s, t = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing='ij')
        h = _noise(rng, (nu, nv), 0.01)
        p = (np.array(o)[None, None] + s[..., None] * np.array(u) + t[..., None] * np.array(v)
             + h[..., None] * np.array(n))
        verts.append(p.reshape(-1, 3))
        tris.append(_grid(nu, nv) + off)
        off += nu * nv
    # Scanned objects: displaced UV spheres on the floor, away from the centre.
    objects = 12
    per = max(40, int(0.2 * triangles / objects))
    ring = max(4, int(np.sqrt(per / 4)))
    for _ in range(objects):
        while True:
            r = rng.uniform(0.2, 0.6)
            c = np.array([rng.uniform(r, room[0] - r), rng.uniform(r, room[1] - r), r])
            if np.hypot(*(c[:2] - ra.CAM[:2])) > r + 0.6:
                break
        nu, nv = ring + 1, 2 * ring
        th, ph = np.meshgrid(np.linspace(0.05, np.pi - 0.05, nu), np.linspace(0, 2 * np.pi, nv, endpoint=False),
                             indexing='ij')
        rad = r * (1 + _noise(rng, (nu, nv), 0.15))
        p = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1) * rad[..., None] + c
        g = _grid(nu, nv + 1)
        g = np.where(g % (nv + 1) == nv, g - nv, g)  # close the seam
        g = g - (g // (nv + 1))                         # re-index to nu × nv
        verts.append(p.reshape(-1, 3))
        tris.append(g + off)
        off += nu * nv
    return np.concatenate(verts), np.concatenate(tris)


def _shelf_boxes(rng, triangles):
    room = ra.ROOM
    n = max(1, triangles // 12 - 60)
    centres, sizes = [], []
    # Shelf units along the long walls and in two rows, boards every 0.4 m.
    units = [(x, y) for x in np.arange(0.5, room[0] - 0.4, 1.0) for y in (0.3, room[1] - 0.3, 1.0, room[1] - 1.0)]
    boards = np.arange(0.2, room[2] - 0.2, 0.4)
    for x, y in units:
        for z in boards:
            centres.append((x, y, z))
            sizes.append((0.9, 0.4, 0.02))
    slots = len(units) * len(boards)
    per_slot = max(1, (n - len(centres)) // slots)
    for x, y in units:
        for z in boards:
            s = rng.uniform(0.03, 0.12, (per_slot, 3))
            cx = x + rng.uniform(-0.4, 0.4, per_slot)
            cy = y + rng.uniform(-0.17, 0.17, per_slot)
            cz = z + 0.01 + s[:, 2] / 2 + rng.uniform(0, 0.2, per_slot)
            centres += list(np.stack([cx, cy, cz], 1))
            sizes += list(s)
    c, s = np.array(centres, float), np.array(sizes, float)
    room_v, room_t = ra._boxes(ra.CAM[None, :], room[None, :], inward=True)
    box_v, box_t = ra._boxes(c, s)
    return np.vstack([room_v, box_v]), np.vstack([room_t, box_t + len(room_v)])


def _clutter(rng, triangles):
    room_v, room_t = ra._boxes(ra.CAM[None, :], ra.ROOM[None, :], inward=True)
    n = max(1, (triangles - len(room_t)) // 12)
    centres = rng.uniform([0.1, 0.1, 0.1], ra.ROOM - 0.1, size=(n, 3))
    sizes = rng.uniform(0.02, 0.08, size=(n, 3))
    box_v, box_t = ra._boxes(centres, sizes, ra._random_rotations(rng, n))
    return np.vstack([room_v, box_v]), np.vstack([room_t, box_t + len(room_v)])


def make(kind, triangles):
    """(float32 vertices (V, 3), int32 triangles (F, 3)) of about `triangles` triangles."""
    rng = np.random.default_rng(ra.SEED + triangles + 7 * KINDS.index(kind))
    v, t = {'scan': _scan, 'boxes': _shelf_boxes, 'clutter': _clutter}[kind](rng, triangles)
    return v.astype(np.float32), t.astype(np.int32)


def write(kind, triangles, ply):
    """Writes the scene as a binary PLY (and a RON scene beside it); returns the RON path."""
    v, t = make(kind, triangles)
    ra.write_ply(ply, v, t)
    ron = os.path.splitext(ply)[0] + '.ron'
    with open(ron, 'w') as f:
        f.write(f'Scene(name: "{kind}{triangles}", objects: [Mesh(name: "m", path: "{os.path.basename(ply)}", '
                'colour: (200, 200, 200))])\n')
    return ron, len(t)


if __name__ == '__main__':
    kind, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    print(write(kind, n, out))
