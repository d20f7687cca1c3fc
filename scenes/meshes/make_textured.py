#!/usr/bin/env python3
"""Writes the textured mesh scenes' files: one crate (a 0.5 m cube whose faces show a
wooden-crate texture) as OBJ + MTL, as PLY with per-face texcoord and a TextureFile comment
(the ScanNet/Matterport convention) and vertex colours, and as a GLB with the texture
embedded. Standard library only, so it runs anywhere; the output is deterministic.

    python3 scenes/meshes/make_textured.py     # rewrites scenes/meshes/crate.*
"""

import json
import pathlib
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent
SIDE = 64  # texture side, texels


def crate_texture():
    """A 64x64 wooden crate face: planks, a frame and a diagonal brace (sRGB rows)."""
    rows = []
    for y in range(SIDE):
        row = []
        for x in range(SIDE):
            plank = (y // 8) % 2
            grain = ((x * 7 + y * 3) % 11) * 3
            r, g, b = (170 + grain, 120 + grain, 70) if plank else (150 + grain, 104 + grain, 60)
            if x < 6 or y < 6 or x >= SIDE - 6 or y >= SIDE - 6 or abs(x - y) < 4:
                r, g, b = 96, 62, 32
            if (y // 8) * 8 == y:
                r, g, b = r - 40, g - 30, b - 20
            row.append((r, g, b))
        rows.append(row)
    return rows


def png(rows):
    """An 8-bit RGB PNG of `rows`."""
    raw = b"".join(b"\x00" + bytes(c for pixel in row for c in pixel) for row in rows)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", len(rows[0]), len(rows), 8, 2, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


# The cube: 8 corners (metres, z up, standing on z = 0) and 6 quads seen from outside, each
# corner with its (u, v) (v down from the image's top row, as glTF; OBJ and PLY get 1 - v).
H = 0.25
CORNERS = [(x, y, z) for z in (0.0, 2 * H) for y in (-H, H) for x in (-H, H)]
QUADS = [
    (4, 5, 7, 6),  # top
    (2, 3, 1, 0),  # bottom
    (6, 7, 3, 2),  # +y
    (5, 4, 0, 1),  # -y
    (7, 5, 1, 3),  # +x
    (4, 6, 2, 0),  # -x
]
QUAD_UV = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
TRIANGLES = [(q, (0, 1, 2)) for q in QUADS] + [(q, (0, 2, 3)) for q in QUADS]


def write_obj():
    lines = ["# A textured crate (scenes/meshes/make_textured.py)", "mtllib crate.mtl", "usemtl crate"]
    lines += [f"v {x} {y} {z}" for x, y, z in CORNERS]
    lines += [f"vt {u} {1.0 - v}" for u, v in QUAD_UV]
    for quad in QUADS:
        lines.append("f " + " ".join(f"{quad[k] + 1}/{k + 1}" for k in range(4)))
    (HERE / "crate.obj").write_text("\n".join(lines) + "\n")
    (HERE / "crate.mtl").write_text("newmtl crate\nKd 1 1 1\nmap_Kd crate.png\n")


def write_ply():
    # Vertex colours: light at the top, darker below (interpolated, times the texture).
    header = [
        "ply",
        "format ascii 1.0",
        "comment A textured crate (scenes/meshes/make_textured.py)",
        "comment TextureFile crate.png",
        f"element vertex {len(CORNERS)}",
        "property float x",
        "property float y",
        "property float z",
        "property uchar red",
        "property uchar green",
        "property uchar blue",
        f"element face {len(TRIANGLES)}",
        "property list uchar int vertex_indices",
        "property list uchar float texcoord",
        "end_header",
    ]
    body = []
    for x, y, z in CORNERS:
        shade = 255 if z > 0 else 170
        body.append(f"{x} {y} {z} {shade} {shade} {shade}")
    for quad, fan in TRIANGLES:
        corners = [quad[k] for k in fan]
        uvs = [f"{QUAD_UV[k][0]} {1.0 - QUAD_UV[k][1]}" for k in fan]
        body.append(f"3 {' '.join(map(str, corners))} 6 {' '.join(uvs)}")
    (HERE / "crate.ply").write_text("\n".join(header + body) + "\n")


def write_glb(texture):
    # glTF is y up: the corners are written as (x, z, -y), and the scene turns them back with
    # rotation: (90, yaw, 0) (Rx(90)·Ry(yaw): a yaw about the glTF's up axis).
    positions, uvs, indices = [], [], []
    for quad in QUADS:
        base = len(positions)
        for k in range(4):
            x, y, z = CORNERS[quad[k]]
            positions.append((x, z, -y))
            uvs.append(QUAD_UV[k])
        indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    binary = b"".join(struct.pack("<3f", *p) for p in positions)
    uv_at = len(binary)
    binary += b"".join(struct.pack("<2f", *uv) for uv in uvs)
    index_at = len(binary)
    binary += b"".join(struct.pack("<H", i) for i in indices)
    binary += b"\x00" * (-len(binary) % 4)
    png_at = len(binary)
    binary += texture
    binary += b"\x00" * (-len(binary) % 4)
    document = {
        "asset": {"version": "2.0", "generator": "scenes/meshes/make_textured.py"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "crate"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [1, 1, 1, 1]}}],
        "textures": [{"source": 0}],
        "images": [{"bufferView": 3, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3",
             "min": [-H, 0.0, -H], "max": [H, 2 * H, H]},
            {"bufferView": 1, "componentType": 5126, "count": len(uvs), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": len(indices), "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": uv_at},
            {"buffer": 0, "byteOffset": uv_at, "byteLength": index_at - uv_at},
            {"buffer": 0, "byteOffset": index_at, "byteLength": 2 * len(indices)},
            {"buffer": 0, "byteOffset": png_at, "byteLength": len(texture)},
        ],
        "buffers": [{"byteLength": len(binary)}],
    }
    text = json.dumps(document, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    glb = b"glTF" + struct.pack("<II", 2, total)
    glb += struct.pack("<I", len(text)) + b"JSON" + text
    glb += struct.pack("<I", len(binary)) + b"BIN\x00" + binary
    (HERE / "crate.glb").write_bytes(glb)


if __name__ == "__main__":
    texture = png(crate_texture())
    (HERE / "crate.png").write_bytes(texture)
    write_obj()
    write_ply()
    write_glb(texture)
