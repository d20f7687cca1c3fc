#!/usr/bin/env python3
"""Writes a glTF scene of many small primitives for the loading benchmark (docs/benchmarks.md,
"2026-11-27 night2 (parts)"), shaped like a Blender export or a scanned room: PRIMITIVES
primitives of TRIANGLES triangles each (a strip of quads, its own POSITION, TEXCOORD_0 and
16-bit index accessors, as exporters write them), spread over the meshes of NODES nodes under
a two-level hierarchy of translated groups, each primitive using one of MATERIALS materials
(every fifth untextured, the others showing one of TEXTURES noise PNGs of SIZE² texels with a
tint), and a scene file that places it.

    python3 bench/make_parts_gltf.py OUT_FOLDER [--primitives 20000] [--triangles 50]
        [--nodes 2000] [--materials 200] [--textures 50] [--size 256]
    omnisim scene check OUT_FOLDER/parts.ron

`--merge` writes the same placed triangles as one primitive (one node, material 0), the
comparison for a shape of many. Standard library only; deterministic.
"""

import argparse
import array
import json
import pathlib

from make_big_gltf import noise_png

GROUPS = 20  # nodes under the root: each holds NODES / GROUPS nodes with meshes


def strip(triangles, part):
    """Corners and texture coordinates of a strip of `triangles` triangles (0.1 m quads along
    x, each primitive of a mesh 0.25 m further along z), and its indices (16-bit: the strips
    stay under 65,536 vertices only when small; larger ones take 32-bit)."""
    positions, uvs = array.array("f"), array.array("f")
    columns = triangles // 2 + 1 + triangles % 2
    for i in range(columns):
        for j in range(2):
            positions.extend((i * 0.1, j * 0.1, part * 0.25))
            uvs.extend((i / max(columns - 1, 1), float(j)))
    wide = 2 * columns > 65535
    indices = array.array("I" if wide else "H")
    for t in range(triangles):
        a = t // 2 * 2  # the quad's first vertex
        if t % 2 == 0:
            indices.extend((a, a + 2, a + 3))
        else:
            indices.extend((a, a + 3, a + 1))
    return positions, uvs, indices, wide


def at_least(least):
    """An argparse type: a whole number of at least `least`."""
    def check(text):
        value = int(text)
        if value < least:
            raise argparse.ArgumentTypeError(f"{value} is not at least {least}")
        return value
    return check


# Counts that divide the parts among them; textures may be 0 (none).
positive = at_least(1)
non_negative = at_least(0)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--primitives", type=positive, default=20000)
    parser.add_argument("--triangles", type=positive, default=50, help="triangles per primitive")
    parser.add_argument("--nodes", type=positive, default=2000, help="nodes with a mesh")
    parser.add_argument("--materials", type=positive, default=200)
    parser.add_argument("--textures", type=non_negative, default=50)
    parser.add_argument("--size", type=positive, default=256, help="texture side in texels")
    parser.add_argument("--merge", action="store_true", help="the same placed triangles as one primitive of material 0")
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    for t in range(args.textures):
        (out / f"tex{t}.png").write_bytes(noise_png(t, args.size))
    binary = bytearray()
    accessors, views = [], []

    def add(data, component, kind, count, extra=None):
        while len(binary) % 4:
            binary.append(0)
        views.append({"buffer": 0, "byteOffset": len(binary), "byteLength": len(data)})
        binary.extend(data)
        accessor = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
        accessor.update(extra or {})
        accessors.append(accessor)
        return len(accessors) - 1

    def primitive(positions, uvs, indices, wide, material):
        vertices = len(positions) // 3
        xs, ys, zs = positions[0::3], positions[1::3], positions[2::3]
        bounds = {"min": [min(xs), min(ys), min(zs)], "max": [max(xs), max(ys), max(zs)]}
        return {
            "attributes": {
                "POSITION": add(positions.tobytes(), 5126, "VEC3", vertices, bounds),
                "TEXCOORD_0": add(uvs.tobytes(), 5126, "VEC2", vertices),
            },
            "indices": add(indices.tobytes(), 5125 if wide else 5123, "SCALAR", len(indices)),
            "material": material,
        }

    per_node = -(-args.primitives // args.nodes)
    groups = min(GROUPS, args.nodes)
    # Where each node's mesh sits: its group's translation along x, its own along z.
    group_x = [g * (args.triangles // 2 + 2) * 0.1 for g in range(groups)]
    node_z = [(n // groups) * (per_node * 0.25 + 0.5) for n in range(args.nodes)]
    meshes, nodes = [], []
    merged = (array.array("f"), array.array("f"), array.array("I"))
    made = 0
    for n in range(args.nodes):
        primitives = []
        for p in range(min(per_node, args.primitives - made)):
            positions, uvs, indices, wide = strip(args.triangles, p)
            vertices = len(positions) // 3
            if args.merge:
                base = len(merged[0]) // 3
                for k in range(vertices):
                    x, y, z = positions[3 * k : 3 * k + 3]
                    merged[0].extend((x + group_x[n % groups], y, z + node_z[n]))
                merged[1].extend(uvs)
                merged[2].extend(i + base for i in indices)
            else:
                primitives.append(primitive(positions, uvs, indices, wide, (made * 7919) % args.materials))
            made += 1
        meshes.append({"primitives": primitives})
        nodes.append({"mesh": n, "translation": [0.0, 0.0, node_z[n]]})
    group_nodes = []
    for g in range(groups):
        nodes.append({"translation": [group_x[g], 0.0, 0.0], "children": list(range(g, args.nodes, groups))})
        group_nodes.append(len(nodes) - 1)
    nodes.append({"rotation": [0.0, 0.0, 0.0, 1.0], "children": group_nodes})
    if args.merge:
        meshes = [{"primitives": [primitive(*merged, True, 0)]}]
        nodes = [{"mesh": 0}]
    materials = []
    for m in range(args.materials):
        material = {"pbrMetallicRoughness": {"baseColorFactor": [1.0 - (m % 7) * 0.05, 1.0, 1.0 - (m % 3) * 0.1, 1.0]}}
        if m % 5 != 4 and args.textures:
            material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": m % args.textures}
        materials.append(material)
    document = {
        "asset": {"version": "2.0", "generator": "bench/make_parts_gltf.py"},
        "scene": 0,
        "scenes": [{"nodes": [len(nodes) - 1]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": t} for t in range(args.textures)],
        "images": [{"uri": f"tex{t}.png"} for t in range(args.textures)],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "parts.bin", "byteLength": len(binary)}],
    }
    (out / "parts.bin").write_bytes(binary)
    (out / "parts.gltf").write_text(json.dumps(document, separators=(",", ":")))
    (out / "parts.ron").write_text(
        'Scene(name: "parts", objects: [Mesh(name: "room", path: "parts.gltf", colour: (255, 255, 255))])\n'
    )


if __name__ == "__main__":
    main()
