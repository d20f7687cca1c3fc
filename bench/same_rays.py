#!/usr/bin/env python3
"""omnisim against Open3D (Embree 4) on the SAME rays, per image.

omnisim writes each camera's ray map (raymap-origin.exr and raymap-direction.exr, body frame);
this script moves those exact rays to the pose and hands them to Open3D's
RaycastingScene.cast_rays (all cores). omnisim is
timed with `omnisim bench` (median ms per image), Open3D with the median of --runs calls.
Rounds alternate the two tools; each tool's best round is kept (a noisy shared machine slows
a round, never speeds it). Prints one JSON line per case and a final table.

Scenes: room, clutter (raycast_anchor.py) and env1 (`omnisim scene export scenes/env1.ron`), and
env1-lit (--scenes env1-lit: scenes/env1-lit.ron, env1's geometry with two point lights): omnisim
renders its lit colour image, Open3D casts the primary rays and then, with test_occlusions, one
shadow ray per light per hit wherever the light is on the side of the face the camera sees (the
rays omnisim's shading casts; lights parsed from the scene file). The shadow rays are made from
a first cast outside the timing, so Open3D's time is its two queries alone; they start 0.1 mm
off the face along its normal towards the camera and end at the light (omnisim starts them
1e-9 x (1 + |p|) off and skips the face itself; f32 needs the larger step), and
with --generated KIND:TRIANGLES,... scenes of bench/scenes.py (scan, boxes, clutter at any size:
scenes the tuning never saw), each with omni 250² (hyperbolic and spherical), equirect 1024² and
pinhole 640×480 from the room centre.
Usage: same_rays.py --omnisim BIN --repo CHECKOUT --work DIR [--rounds 3] [--cases all|quick|models] [--scenes room,env1]
       [--generated scan:100000,boxes:1000000]
Needs open3d-cpu, numpy, OpenEXR: same_rays.sh makes the venv and runs this.
"""
import argparse, json, os, re, statistics, subprocess, sys, time
import numpy as np
import open3d as o3d
import OpenEXR

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import raycast_anchor as ra  # noqa: E402
import scenes as generated_scenes  # noqa: E402

def write_ply(path, v, t):
    ra.write_ply(path, v.astype(np.float32), t.astype(np.int32))

def scene_files(work, repo, omnisim):
    cache = os.environ.get('BENCH_CACHE', os.path.expanduser('~/.cache/omnisim-bench'))
    out = {}
    for name in ('room', 'clutter'):
        p = os.path.join(work, f'scene_{name}.ply')
        if not os.path.exists(p):
            v, t = ra.build_scene(name); write_ply(p, v, t)
        out[name] = p
    p = os.path.join(work, 'scene_env1.ply')
    if not os.path.exists(p):
        subprocess.run([omnisim, 'scene', 'export', os.path.join(repo, 'scenes', 'env1.ron'), p], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out['env1'] = p
    lit = os.path.join(work, 'scene_env1-lit.ply')
    if not os.path.exists(lit):
        subprocess.run([omnisim, 'scene', 'export', os.path.join(repo, 'scenes', 'env1-lit.ron'), lit], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rons = {'env1-lit': os.path.join(repo, 'scenes', 'env1-lit.ron')}
    for name, ply in list(out.items()):
        ron = os.path.join(work, f'{name}.ron')
        with open(ron, 'w') as f:
            f.write(f'Scene(name: "{name}", objects: [Mesh(name: "{name}", path: "{os.path.basename(ply)}", colour: (200, 200, 200))])\n')
        rons[name] = ron
    out['env1-lit'] = lit
    return out, rons

def point_lights(ron):
    """Positions of the point lights switched on in a scene file (the only kind env1-lit has)."""
    text = open(ron).read()
    if re.search(r'\b(Directional|Spot)\s*\(', text):
        sys.exit(f'{ron}: only point lights are handled here')
    lights = []
    for m in re.finditer(r'Point\((.*?)\),?\s*$', text, re.M):
        body = m.group(1)
        if re.search(r'\bon:\s*false', body):
            continue
        pos = re.search(r'position:\s*\(([^)]*)\)', body).group(1)
        lights.append([float(x) for x in pos.split(',')])
    if not lights:
        sys.exit(f'{ron}: no point light found')
    return np.array(lights)

def shadow_rays(scene, rays, lights):
    """One ray per hit and light, from the hit to the light, where the light is on the side of
    the face the camera sees (as omnisim's shading casts them): origin 0.1 mm off the face,
    direction = light - origin, so that t in [0, 1] spans the way to the light."""
    r = scene.cast_rays(o3d.core.Tensor(rays))
    t = r['t_hit'].numpy()
    hit = np.isfinite(t)
    o = rays[hit, :3].astype(np.float64) + rays[hit, 3:].astype(np.float64) * t[hit, None]
    n = r['primitive_normals'].numpy()[hit].astype(np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n[(n * rays[hit, 3:]).sum(1) > 0] *= -1
    out = []
    for light in lights:
        towards = light - o
        lit = (n * towards).sum(1) > 0
        origin = o[lit] + 1e-4 * n[lit]
        out.append(np.hstack([origin, light - origin]))
    return np.vstack(out).astype(np.float32), int(hit.sum())

def time_open3d_lit(scene, rays, shadows, runs):
    """Median of the primary cast plus the shadow rays' any-hit test."""
    t, s = o3d.core.Tensor(rays), o3d.core.Tensor(shadows)
    scene.cast_rays(t); scene.test_occlusions(s, tnear=0.0, tfar=1.0)
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter()
        scene.cast_rays(t)['t_hit'].numpy()
        blocked = scene.test_occlusions(s, tnear=0.0, tfar=1.0).numpy()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts), float(blocked.mean())

def read_xyz(path):
    """One ray-map file: channels R G B = x y z, one row per pixel."""
    ch = OpenEXR.File(path, separate_channels=True).channels()
    return np.stack([ch[k].pixels for k in 'RGB'], -1).reshape(-1, 3).astype(np.float64)

def read_raymap(folder):
    o = read_xyz(os.path.join(folder, 'raymap-origin.exr'))
    d = read_xyz(os.path.join(folder, 'raymap-direction.exr'))
    ok = np.isfinite(d).all(1)
    return o[ok], d[ok]

def world_rays(omnisim, ron, cam_args, pose, work, tag):
    out = os.path.join(work, 'rm-' + tag)
    subprocess.run([omnisim, 'render', ron, *cam_args, '--pose', pose, '--backend', 'cpu', '--out', out, '--overwrite'],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    js = json.load(open(os.path.join(out, 'render.json')))
    M = np.array(js['frames'][0]['world_from_body'])
    o, d = read_raymap(out)
    O = o @ M[:3, :3].T + M[:3, 3]; D = d @ M[:3, :3].T
    return np.hstack([O, D]).astype(np.float32)

def time_open3d(scene, rays, runs):
    t = o3d.core.Tensor(rays)
    scene.cast_rays(t)
    ts = []
    for _ in range(runs):
        t0 = time.perf_counter(); r = scene.cast_rays(t); r['t_hit'].numpy(); ts.append(time.perf_counter() - t0)
    return statistics.median(ts)

def time_omnisim(omnisim, ron, cam_args, pose, runs, extra):
    p = subprocess.run([omnisim, 'bench', ron, *cam_args, '--pose', pose, '--backend', 'cpu', '--runs', str(runs), *extra],
                       check=True, capture_output=True, text=True)
    js = [json.loads(l) for l in p.stdout.splitlines() if l.strip()][0]
    return js['median_ms'] / 1e3, js

CAMS = {
    'equirect1024': ['--camera', 'equirect', '--size', '1024x1024'],
    'pinhole640': ['--camera', 'pinhole', '--size', '640x480', '--hfov', '60'],
    'omni250': ['--camera', 'omni', '--size', '250x250'],
    'omni1000': ['--camera', 'omni', '--size', '1000x1000'],
    'cylindrical1024': ['--camera', 'cylindrical', '--size', '1024x256', '--vfov', '80'],
    'omni250-parabolic': ['--camera', 'omni', '--size', '250x250', '--mirror', 'parabolic', '--mirror-b', '0.05'],
    'omni250-spherical': ['--camera', 'omni', '--size', '250x250', '--mirror', 'spherical', '--mount', 'down'],
}

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--omnisim', required=True); ap.add_argument('--repo', required=True)
    ap.add_argument('--work', required=True); ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--runs', type=int, default=5); ap.add_argument('--cases', default='all')
    ap.add_argument('--scenes', default='room,clutter,env1')
    ap.add_argument('--extra', default='', help='extra omnisim bench flags, e.g. "--hits-only"')
    ap.add_argument('--generated', default='', help='bench/scenes.py scenes, e.g. scan:100000,boxes:1000000')
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    plys, rons = scene_files(a.work, a.repo, a.omnisim)
    generated = []
    for spec in filter(None, a.generated.split(',')):
        kind, count = spec.split(':')
        name = f'{kind}{count}'
        plys[name] = os.path.join(a.work, f'scene_{name}.ply')
        if not os.path.exists(plys[name]):
            generated_scenes.write(kind, int(count), plys[name])
        rons[name] = os.path.splitext(plys[name])[0] + '.ron'
        generated.append(name)
    cases = []
    for s in ('room', 'clutter'):
        for pose in ('3,2,1.5,0,0,0', '3.01,2.01,1.51,0,0,30', '1.2,0.9,0.7,10,-20,200'):
            cases.append((s, 'equirect1024', pose))
        cases.append((s, 'pinhole640', '1.2,0.9,0.7,0,-10,30'))
        cases.append((s, 'omni250', '3,2,1.5,0,0,60'))
    cases += [('env1', 'omni250', '1.5,0,0.4,0,0,60'), ('env1', 'omni1000', '1.5,0,0.4,0,50,60'),
              ('env1', 'equirect1024', '0,0,0.4,0,0,0'), ('env1', 'pinhole640', '-1,0.3,0.6,0,-5,20')]
    # Lit: env1's poses, the lit scene (its shadow rays timed on both sides).
    cases += [('env1-lit', cam, pose) for (_, cam, pose) in cases[-4:] if cam != 'omni1000']
    # The other camera models and mirrors (--cases models: these alone), at env1's paper pose
    # and in clutter at the room centre.
    models = [(s, cam, pose) for s, pose in (('env1', '1.5,0,0.4,0,0,60'), ('clutter', '3,2,1.5,0,0,60'))
              for cam in ('cylindrical1024', 'omni250-parabolic', 'omni250-spherical')]
    if a.cases == 'models':
        cases = models
    elif a.cases == 'all':
        cases += models
    if a.cases == 'quick':
        cases = [c for c in cases if c[1] != 'equirect1024' or c[2].startswith('3,2')]
    extra = a.extra.split()
    cases = [c for c in cases if c[0] in a.scenes.split(',')]
    cases += [(name, cam, '3,2,1.5,0,0,60') for name in generated
              for cam in ('omni250', 'omni250-spherical', 'equirect1024', 'pinhole640')]
    rows = []
    scenes = {}
    for (s, cam, pose) in cases:
        if s not in scenes:
            try:
                v, t = ra.read_ply(plys[s])
            except AssertionError:  # polygons (scene export): let Open3D triangulate
                m = o3d.io.read_triangle_mesh(plys[s])
                v, t = np.asarray(m.vertices), np.asarray(m.triangles)
            sc = o3d.t.geometry.RaycastingScene()
            sc.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(t.astype(np.uint32)))
            scenes = {s: (sc, len(t))}
        sc, ntri = scenes[s]
        rays = world_rays(a.omnisim, rons[s], CAMS[cam], pose, a.work, f'{s}-{cam}')
        lit = s.endswith('-lit')
        if lit:
            shadows, hits = shadow_rays(sc, rays, point_lights(rons[s]))
        best_o3d = best_om = float('inf'); js = None; blocked = None
        for _ in range(a.rounds):
            if lit:
                t, blocked = time_open3d_lit(sc, rays, shadows, a.runs)
            else:
                t = time_open3d(sc, rays, a.runs)
            best_o3d = min(best_o3d, t)
            t, js = time_omnisim(a.omnisim, rons[s], CAMS[cam], pose, a.runs, extra)
            best_om = min(best_om, t)
        row = dict(scene=s, triangles=ntri, camera=cam, pose=pose, rays=len(rays),
                   open3d_ms=1e3 * best_o3d, omnisim_ms=1e3 * best_om, ratio=best_o3d / best_om,
                   omnisim_tracer=js.get('tracer'), planes=js.get('planes'))
        if lit:
            row.update(hits=hits, shadow_rays=len(shadows), shadowed=blocked)
        rows.append(row); print(json.dumps(row), flush=True)
    print(f"\n{'scene':8} {'tris':>9} {'camera':13} {'pose':24} {'rays':>8} {'open3d ms':>10} {'omnisim ms':>10} {'ratio':>6}")
    for r in rows:
        print(f"{r['scene']:8} {r['triangles']:9d} {r['camera']:13} {r['pose']:24} {r['rays']:8d} {r['open3d_ms']:10.2f} {r['omnisim_ms']:10.2f} {r['ratio']:5.2f}x")
    rs = [r['ratio'] for r in rows]
    print(f"worst {min(rs):.2f}x  median {statistics.median(rs):.2f}x  best {max(rs):.2f}x over {len(rs)} cases")

if __name__ == '__main__':
    main()
