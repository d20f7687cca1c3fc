#!/usr/bin/env python3
"""Writes an OBJ + MTL scene of many small groups for the loading benchmark (docs/benchmarks.md,
"2026-11-27 night2 (parts)"), shaped like a Matterport house: GROUPS groups (`o`) of TRIANGLES
triangles each (the strips of make_parts_gltf.py, each group 0.25 m further along z), each
group under `usemtl` of one of MATERIALS materials (`Kd`, and every material but each fifth
a `map_Kd` of one of TEXTURES noise PNGs of SIZE² texels), and a scene file that places it.

    python3 bench/make_parts_obj.py OUT_FOLDER [--groups 20000] [--triangles 50]
        [--materials 100] [--textures 100] [--size 256]
    omnisim scene check OUT_FOLDER/parts.ron

`--groups 1 --materials 1` with as many triangles writes one group, the comparison.
Standard library only; deterministic.
"""

import argparse
import pathlib

from make_big_gltf import noise_png
from make_parts_gltf import non_negative, positive, strip


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--groups", type=positive, default=20000)
    parser.add_argument("--triangles", type=positive, default=50, help="triangles per group")
    parser.add_argument("--materials", type=positive, default=100)
    parser.add_argument("--textures", type=non_negative, default=100)
    parser.add_argument("--size", type=positive, default=256, help="texture side in texels")
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    for t in range(args.textures):
        (out / f"tex{t}.png").write_bytes(noise_png(t, args.size))
    mtl = []
    for m in range(args.materials):
        mtl.append(f"newmtl m{m}\nKd {1.0 - (m % 7) * 0.05:.2f} 1.0 {1.0 - (m % 3) * 0.1:.2f}\n")
        if m % 5 != 4 and args.textures:
            mtl.append(f"map_Kd tex{m % args.textures}.png\n")
    (out / "parts.mtl").write_text("".join(mtl))
    lines = ["mtllib parts.mtl\n"]
    vertices = 0
    for g in range(args.groups):
        positions, uvs, indices, _ = strip(args.triangles, g)
        lines.append(f"o part{g}\nusemtl m{(g * 7919) % args.materials}\n")
        lines.extend(f"v {positions[k]:.4f} {positions[k + 1]:.4f} {positions[k + 2]:.4f}\n" for k in range(0, len(positions), 3))
        lines.extend(f"vt {uvs[k]:.4f} {uvs[k + 1]:.4f}\n" for k in range(0, len(uvs), 2))
        for k in range(0, len(indices), 3):
            a, b, c = (vertices + i + 1 for i in indices[k : k + 3])
            lines.append(f"f {a}/{a} {b}/{b} {c}/{c}\n")
        vertices += len(positions) // 3
    (out / "parts.obj").write_text("".join(lines))
    (out / "parts.ron").write_text(
        'Scene(name: "parts", objects: [Mesh(name: "room", path: "parts.obj", colour: (255, 255, 255))])\n'
    )


if __name__ == "__main__":
    main()
