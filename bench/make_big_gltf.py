#!/usr/bin/env python3
"""Writes a large textured glTF scene for the loading benchmark (docs/benchmarks.md,
"Textured scenes"): a .gltf + .bin of about 1 M triangles (a 708 x 708 grid of quads, cut
into four primitives) whose four materials each use their own 2048 x 2048 PNG of noise
(about 12.6 MB each, 50 MB in all), and a scene file that places it.

    python3 bench/make_big_gltf.py OUT_FOLDER      # then: omnisim scene check OUT_FOLDER/big.ron

Standard library only; deterministic.
"""

import array
import json
import pathlib
import random
import struct
import sys
import zlib

SIDE = 708  # quads per side: 2 * 708^2 = 1,002,528 triangles
TEXTURE = 2048
PARTS = 4


def noise_png(seed, side=TEXTURE):
    """An RGB PNG of side x side texels of seeded noise."""
    rng = random.Random(seed)
    row_bytes = side * 3
    raw = b"".join(b"\x00" + rng.randbytes(row_bytes) for _ in range(side))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", side, side, 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 1)) + chunk(b"IEND", b"")


def main(out):
    out.mkdir(parents=True, exist_ok=True)
    positions = array.array("f")
    uvs = array.array("f")
    for j in range(SIDE + 1):
        for i in range(SIDE + 1):
            positions.extend((i / SIDE * 10.0, 0.0, -j / SIDE * 10.0))  # y up: a 10 m floor
            uvs.extend((i / SIDE * 8.0, j / SIDE * 8.0))
    rows_per_part = SIDE // PARTS
    parts = []
    binary = bytearray(positions.tobytes() + uvs.tobytes())
    for p in range(PARTS):
        indices = array.array("I")
        rows = range(p * rows_per_part, SIDE if p == PARTS - 1 else (p + 1) * rows_per_part)
        for j in rows:
            for i in range(SIDE):
                a = j * (SIDE + 1) + i
                b, c, d = a + 1, a + SIDE + 2, a + SIDE + 1
                indices.extend((a, b, c, a, c, d))
        parts.append((len(binary), len(indices)))
        binary += indices.tobytes()
    (out / "big.bin").write_bytes(binary)
    for p in range(PARTS):
        (out / f"noise{p}.png").write_bytes(noise_png(p))
    vertices = (SIDE + 1) ** 2
    document = {
        "asset": {"version": "2.0", "generator": "bench/make_big_gltf.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2 + p, "material": p} for p in range(PARTS)
        ]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": p}}} for p in range(PARTS)],
        "textures": [{"source": p} for p in range(PARTS)],
        "images": [{"uri": f"noise{p}.png"} for p in range(PARTS)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3",
             "min": [0.0, 0.0, -10.0], "max": [10.0, 0.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": vertices, "type": "VEC2"},
        ] + [{"bufferView": 2 + p, "componentType": 5125, "count": count, "type": "SCALAR"}
             for p, (_, count) in enumerate(parts)],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 12 * vertices},
            {"buffer": 0, "byteOffset": 12 * vertices, "byteLength": 8 * vertices},
        ] + [{"buffer": 0, "byteOffset": offset, "byteLength": 4 * count} for offset, count in parts],
        "buffers": [{"uri": "big.bin", "byteLength": len(binary)}],
    }
    (out / "big.gltf").write_text(json.dumps(document))
    (out / "big.ron").write_text(
        'Scene(name: "big", objects: [Mesh(name: "floor", path: "big.gltf", colour: (255, 255, 255), '
        "rotation: (90.0, 0.0, 0.0))])\n"
    )


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(pathlib.Path(sys.argv[1]))
