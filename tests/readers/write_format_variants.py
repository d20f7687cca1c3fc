"""Writes the mesh files that users and independent checkers bring, one scene per variant, with
what omnisim must read from each (tests/tests/textures.rs,
`files_from_independent_writers_read_as_their_formats_define`, reads them back and compares).

    python tests/readers/write_format_variants.py FOLDER

Writers: pygltflib (glTF and GLB containers), trimesh (GLB, PLY), plyfile (PLY in every
encoding and list type), Open3D (PLY), Pillow and a PNG writer here (image variants), and OBJ
and MTL by hand (OBJ is text). FOLDER/cases.json lists every case:

- `name`, `scene` (the RON file beside it) and `writer`;
- `refuse`: null for a file omnisim must read, else words its error must contain;
- `faces`: each triangle's world corners in the winding the format defines (glTF strips: odd
  triangles flipped; fans: around vertex 0; n-gons: fans around their first corner), compared
  up to a rotation of the corners;
- optional `colours` (each face's sRGB colour), `uvs` (each face's corner texture coordinates,
  v down from the image's top row), `corner_colours` (each corner's sRGB colour) and `texel`
  (`x`, `y`, `rgb`: a texel of the scene's first texture at full size).

Every expectation is computed here from the format's specification, not from omnisim.
"""
import json
import math
import pathlib
import struct
import sys
import zlib

import numpy as np
import open3d as o3d
import plyfile
import pygltflib
import trimesh
from PIL import Image

CASES = []


def srgb(linear):
    """The sRGB byte of a linear value in [0, 1] (IEC 61966-2-1)."""
    linear = min(max(linear, 0.0), 1.0)
    value = 12.92 * linear if linear <= 0.0031308 else 1.055 * linear ** (1 / 2.4) - 0.055
    return int(round(value * 255))


def case(folder, name, mesh, writer, faces=None, refuse=None, **expected):
    """Writes NAME.ron placing `mesh` (white, at the origin, unscaled) and records the case."""
    (folder / f"{name}.ron").write_text(
        f'Scene(name: "{name}", objects: [Mesh(name: "mesh", path: "{mesh}", colour: (9, 9, 9))])\n')
    CASES.append({"name": name, "scene": f"{name}.ron", "writer": writer, "refuse": refuse,
                  "faces": faces, **expected})


# ---------------------------------------------------------------- images

def png(width, height, colour_type, depth, rows, palette=None):
    """A PNG of `rows` (lists of samples per row), written here (zlib, no filter)."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    sample = ">H" if depth == 16 else ">B"
    raw = b"".join(b"\0" + b"".join(struct.pack(sample, s) for s in row) for row in rows)
    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, colour_type, 0, 0, 0))
    if palette is not None:
        out += chunk(b"PLTE", bytes(c for rgb in palette for c in rgb))
    return out + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


# A 2×2 image's texels (sRGB), row by row: the texel at (1, 0) is checked.
TEXELS = [[(200, 30, 60), (20, 180, 90)], [(10, 20, 250), (240, 240, 10)]]


def tiles_png():
    """TEXELS as an 8-bit RGB PNG."""
    return png(2, 2, 2, 8, [[c for rgb in row for c in rgb] for row in TEXELS])


def image_variants():
    """(name, file bytes, the texel at (1, 0) as it must read) of each image kind."""
    flat = [[c for rgb in row for c in rgb] for row in TEXELS]
    out = [("rgb8", tiles_png(), TEXELS[0][1])]
    wide = [[c * 257 + 3 for c in row] for row in flat]
    out.append(("rgb16", png(2, 2, 2, 16, wide), tuple(round((c * 257 + 3) / 257) for c in TEXELS[0][1])))
    out.append(("rgba8", png(2, 2, 6, 8, [[c for rgb in row for c in (*rgb, 128)] for row in TEXELS]), TEXELS[0][1]))
    out.append(("grey8", png(2, 2, 0, 8, [[77, 150], [3, 255]]), (150, 150, 150)))
    out.append(("grey16", png(2, 2, 0, 16, [[77 * 257, 150 * 257], [3, 65535]]), (150, 150, 150)))
    out.append(("greyalpha8", png(2, 2, 4, 8, [[77, 10, 150, 200], [3, 0, 255, 255]]), (150, 150, 150)))
    palette = [rgb for row in TEXELS for rgb in row]
    out.append(("palette", png(2, 2, 3, 8, [[0, 1], [2, 3]], palette), TEXELS[0][1]))
    return out


def tiles_image():
    """TEXELS as a Pillow image (the TGA, BMP and WebP variants)."""
    image = Image.new("RGB", (2, 2))
    image.putdata([rgb for row in TEXELS for rgb in row])
    return image


def pillow_bytes(**save):
    """TEXELS saved by Pillow with `save`'s arguments."""
    import io
    buffer = io.BytesIO()
    tiles_image().save(buffer, **save)
    return buffer.getvalue()


# (name, file extension, Pillow's save arguments) of the texture files OBJ and PLY scans ship
# besides PNG and JPEG (Matterport- and ScanNet-era exports).
SCAN_IMAGES = [("tga", "tga", dict(format="TGA")), ("tga-rle", "tga", dict(format="TGA", compression="tga_rle")),
               ("bmp", "bmp", dict(format="BMP"))]


def jpeg(progressive):
    """A 16×16 JPEG of one colour (lossy: the texel is checked within a few levels)."""
    import io
    buffer = io.BytesIO()
    Image.new("RGB", (16, 16), (180, 90, 40)).save(buffer, "JPEG", quality=95, progressive=progressive)
    return buffer.getvalue()


# ---------------------------------------------------------------- glTF through pygltflib

STRIP = [(0, 0, 0), (0, 1, 0.1), (1, 0, 0.2), (1, 1, 0.3), (2, 0, 0.4), (2, 1, 0.5)]
FAN = [(0, 0, 0), (1, 0, 0), (1, 1, 0.1), (0, 1, 0.2), (-1, 0.5, 0.3)]


def triangles_of(mode, count, indices=None):
    """The corner indices of each triangle of a glTF primitive (spec 3.7.2.1)."""
    at = indices if indices is not None else list(range(count))
    n = len(at)
    if mode == 4:
        return [(at[i], at[i + 1], at[i + 2]) for i in range(0, n - n % 3, 3)]
    if mode == 5:
        return [(at[i], at[i + 1 + i % 2], at[i + 2 - i % 2]) for i in range(n - 2)]
    if mode == 6:
        return [(at[i + 1], at[i + 2], at[0]) for i in range(n - 2)]
    raise ValueError(mode)


class Blob:
    """A glTF binary buffer being written: views 4-byte aligned."""

    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def view(self, data, stride=None):
        while len(self.data) % 4:
            self.data.append(0)
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.data += data
        self.views.append(view)
        return len(self.views) - 1

    def accessor(self, values, component, kind, normalized=False, stride=None, minmax=False):
        """An accessor of `values` (tuples) packed tightly, or `stride` apart (padded)."""
        code = {"b": 5120, "B": 5121, "h": 5122, "H": 5123, "I": 5125, "f": 5126}[component]
        size = struct.calcsize("<" + component) * len(values[0])
        packed = b""
        for v in values:
            item = struct.pack("<" + component * len(v), *v)
            packed += item + b"\0" * ((stride or size) - size)
        accessor = {"bufferView": self.view(packed, stride), "componentType": code, "count": len(values),
                    "type": kind}
        if normalized:
            accessor["normalized"] = True
        if minmax:
            accessor["min"] = [min(v[k] for v in values) for k in range(len(values[0]))]
            accessor["max"] = [max(v[k] for v in values) for k in range(len(values[0]))]
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def raw_accessor(self, accessor):
        self.accessors.append(accessor)
        return len(self.accessors) - 1


def save_gltf(folder, file, document, blob, required=(), embed=None):
    """Writes `document` with the buffer `blob` through pygltflib: a GLB, or a .gltf whose
    buffer is a data URI (`embed`) or a .bin beside it."""
    document = dict(document)
    document.setdefault("asset", {"version": "2.0", "generator": "omnisim write_format_variants.py"})
    document["accessors"] = blob.accessors
    document["bufferViews"] = blob.views
    document["buffers"] = [{"byteLength": len(blob.data)}]
    used = set(document.get("extensionsUsed", [])) | set(required)
    if used:
        document["extensionsUsed"] = sorted(used)
    if required:
        document["extensionsRequired"] = sorted(required)
    gltf = pygltflib.GLTF2.from_json(json.dumps(document))
    gltf.set_binary_blob(bytes(blob.data))
    if file.endswith(".glb"):
        gltf.save_binary(str(folder / file))
    else:
        if embed:
            gltf.convert_buffers(pygltflib.BufferFormat.DATAURI)
        else:
            gltf.buffers[0].uri = file.replace(".gltf", ".bin")
            (folder / gltf.buffers[0].uri).write_bytes(bytes(blob.data))
            gltf._glb_data = None
        gltf.save_json(str(folder / file))


def node_world(points, scale=(1, 1, 1), translation=(0, 0, 0)):
    return [tuple(p[k] * scale[k] + translation[k] for k in range(3)) for p in points]


def one_mesh(primitive, nodes=None, materials=None, **extra):
    document = {"scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes or [{"mesh": 0}],
                "meshes": [{"primitives": [primitive]}]}
    if materials is not None:
        document["materials"] = materials
    document.update(extra)
    return document


def textured(folder, attributes, info=None, nodes=None, uri="tiles.png"):
    """A document of one strip of `attributes` whose material shows the 2×2 `tiles.png`
    (written into `folder`) through the texture info `info`."""
    (folder / "tiles.png").write_bytes(tiles_png())
    primitive = {"attributes": attributes, "mode": 5, "material": 0}
    return one_mesh(primitive, nodes=nodes, textures=[{"source": 0}], images=[{"uri": uri}],
                    materials=[{"pbrMetallicRoughness": {"baseColorTexture": info or {"index": 0}}}])


def faces_of(points, triangles):
    return [[list(points[i]) for i in t] for t in triangles]


def gltf_topology(folder):
    """Triangles, strips and fans, indexed (u8, u16, u32) and not."""
    for mode, points, label in [(4, STRIP, "triangles"), (5, STRIP, "strip"), (6, FAN, "fan")]:
        indexed = list(range(len(points)))
        if mode == 4:
            indexed = [0, 1, 2, 2, 1, 3, 2, 3, 4, 4, 3, 5]
        for component in [None, "B", "H", "I"]:
            blob = Blob()
            position = blob.accessor(points, "f", "VEC3", minmax=True)
            primitive = {"attributes": {"POSITION": position}, "mode": mode}
            if component:
                # Reversed vertex order in the buffer, so that an index read as a position is caught.
                primitive["indices"] = blob.accessor([(i,) for i in indexed], component, "SCALAR")
            name = f"gltf-{label}-{ {None: 'plain', 'B': 'u8', 'H': 'u16', 'I': 'u32'}[component] }"
            save_gltf(folder, f"{name}.glb", one_mesh(primitive), blob)
            triangles = triangles_of(mode, len(points), indexed if component else None)
            case(folder, name, f"{name}.glb", "pygltflib", faces_of(points, triangles))


def gltf_interleaved(folder):
    """Positions and texture coordinates interleaved in one view (byteStride 20)."""
    blob = Blob()
    uvs = [(p[0] / 2, p[1]) for p in STRIP]
    packed = b"".join(struct.pack("<5f", *p, *uv) for p, uv in zip(STRIP, uvs))
    view = blob.view(packed, 20)
    position = blob.raw_accessor({"bufferView": view, "byteOffset": 0, "componentType": 5126, "count": 6,
                                  "type": "VEC3", "min": [0, 0, 0], "max": [2, 1, 0.5]})
    texcoord = blob.raw_accessor({"bufferView": view, "byteOffset": 12, "componentType": 5126, "count": 6,
                                  "type": "VEC2"})
    document = textured(folder, {"POSITION": position, "TEXCOORD_0": texcoord})
    save_gltf(folder, "gltf-interleaved.gltf", document, blob)
    triangles = triangles_of(5, 6)
    case(folder, "gltf-interleaved", "gltf-interleaved.gltf", "pygltflib", faces_of(STRIP, triangles),
         uvs=[[list(uvs[i]) for i in t] for t in triangles], texel={"x": 1, "y": 0, "rgb": TEXELS[0][1]})


def dequantize(q, component, normalized):
    if not normalized:
        return float(q)
    return {"b": max(q / 127, -1.0), "B": q / 255, "h": max(q / 32767, -1.0), "H": q / 65535}[component]


def gltf_quantization(folder):
    """KHR_mesh_quantization: integer positions (a node scale brings them to metres) and
    normalized integer texture coordinates, as gltfpack writes them."""
    limits = {"b": 127, "B": 255, "h": 32767, "H": 65535}
    for component in "bBhH":
        for normalized in [True, False]:
            top = limits[component] if normalized else {"b": 100, "B": 200, "h": 1000, "H": 1000}[component]
            signed = component in "bh"
            quantized = [tuple(int(round(c / 2 * top)) for c in p) for p in STRIP]
            if signed:
                quantized = [tuple(-c if k == 1 else c for k, c in enumerate(p)) for p in quantized]
            blob = Blob()
            size = struct.calcsize(component) * 3
            stride = (size + 3) // 4 * 4
            position = blob.accessor(quantized, component, "VEC3", normalized, stride=stride, minmax=True)
            scale = (2.0, 2.0, 2.0) if normalized else (2 / top,) * 3
            uv_quantized = [(int(round(p[0] / 2 * 255)), int(round(p[1] * 255))) for p in STRIP]
            texcoord = blob.accessor(uv_quantized, "B", "VEC2", normalized=True, stride=4)
            document = textured(folder, {"POSITION": position, "TEXCOORD_0": texcoord},
                                nodes=[{"mesh": 0, "scale": list(scale)}])
            name = f"gltf-quantized-{ {'b': 'i8', 'B': 'u8', 'h': 'i16', 'H': 'u16'}[component] }" + (
                "-normalized" if normalized else "")
            save_gltf(folder, f"{name}.glb", document, blob, required=["KHR_mesh_quantization"])
            points = [tuple(dequantize(c, component, normalized) * scale[k] for k, c in enumerate(p))
                      for p in quantized]
            uvs = [(u / 255, v / 255) for u, v in uv_quantized]
            triangles = triangles_of(5, 6)
            case(folder, name, f"{name}.glb", "pygltflib", faces_of(points, triangles),
                 uvs=[[list(uvs[i]) for i in t] for t in triangles])
    # u16 texture coordinates not normalized, brought to [0, 1] by KHR_texture_transform's scale.
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    uv_quantized = [(int(p[0] * 512), int(p[1] * 1024)) for p in STRIP]
    texcoord = blob.accessor(uv_quantized, "H", "VEC2", stride=4)
    transform = {"KHR_texture_transform": {"scale": [1 / 1024, 1 / 1024]}}
    document = textured(folder, {"POSITION": position, "TEXCOORD_0": texcoord}, {"index": 0, "extensions": transform})
    save_gltf(folder, "gltf-quantized-uv-u16.glb", document, blob,
              required=["KHR_mesh_quantization", "KHR_texture_transform"])
    scale = float(np.float32(1 / 1024))
    uvs = [(u * scale, v * scale) for u, v in uv_quantized]
    triangles = triangles_of(5, 6)
    case(folder, "gltf-quantized-uv-u16", "gltf-quantized-uv-u16.glb", "pygltflib", faces_of(STRIP, triangles),
         uvs=[[list(uvs[i]) for i in t] for t in triangles])


def gltf_colours(folder):
    """COLOR_0 as VEC3 and VEC4 in f32, normalized u8 and normalized u16, times the factor."""
    linear = [(0.1 * i, 1 - 0.15 * i, 0.5, 1.0) for i in range(6)]
    factor = [0.5, 1.0, 0.8, 1.0]
    for kind in ["VEC3", "VEC4"]:
        for component, top in [("f", 1.0), ("B", 255), ("H", 65535)]:
            width = 3 if kind == "VEC3" else 4
            values = [tuple(c[:width]) if component == "f" else tuple(int(round(x * top)) for x in c[:width])
                      for c in linear]
            blob = Blob()
            position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
            size = struct.calcsize(component) * width
            colour = blob.accessor(values, component, kind, normalized=component != "f", stride=(size + 3) // 4 * 4)
            primitive = {"attributes": {"POSITION": position, "COLOR_0": colour}, "mode": 5, "material": 0}
            document = one_mesh(primitive, materials=[{"pbrMetallicRoughness": {"baseColorFactor": factor}}])
            name = f"gltf-colour-{kind.lower()}-{ {'f': 'f32', 'B': 'u8', 'H': 'u16'}[component] }"
            save_gltf(folder, f"{name}.glb", document, blob)
            read = [[(v / top if component != "f" else float(np.float32(v))) for v in c] for c in values]
            corner = [[srgb(c[k] * factor[k]) for k in range(3)] for c in read]
            triangles = triangles_of(5, 6)
            case(folder, name, f"{name}.glb", "pygltflib", faces_of(STRIP, triangles),
                 corner_colours=[[corner[i] for i in t] for t in triangles],
                 colours=[[srgb(f) for f in factor[:3]]] * len(triangles))


def gltf_texcoord_sets(folder):
    """TEXCOORD_1 picked by texCoord 1, and KHR_texture_transform's own texCoord."""
    first = [(0.0, 0.0)] * 6
    second = [(p[0] / 2, p[1]) for p in STRIP]
    for name, info in [("gltf-texcoord-1", {"index": 0, "texCoord": 1}),
                       ("gltf-transform-texcoord", {"index": 0, "texCoord": 0, "extensions": {
                           "KHR_texture_transform": {"texCoord": 1, "offset": [0.25, 0.5]}}})]:
        blob = Blob()
        position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
        uv0 = blob.accessor(first, "f", "VEC2")
        uv1 = blob.accessor(second, "f", "VEC2")
        document = textured(folder, {"POSITION": position, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1}, info)
        save_gltf(folder, f"{name}.gltf", document, blob,
                  required=["KHR_texture_transform"] if "extensions" in info else ())
        offset = (0.25, 0.5) if "extensions" in info else (0.0, 0.0)
        uvs = [(u + offset[0], v + offset[1]) for u, v in second]
        triangles = triangles_of(5, 6)
        case(folder, name, f"{name}.gltf", "pygltflib", faces_of(STRIP, triangles),
             uvs=[[list(uvs[i]) for i in t] for t in triangles])


def gltf_sparse_and_viewless(folder):
    """Sparse positions over a base view, sparse positions over no view (zeros), and texture
    coordinates without a view (all zeros, as the spec says)."""
    moved = {1: (0.0, 1.0, 1.5), 4: (2.0, 0.0, -1.0)}
    for base in [True, False]:
        blob = Blob()
        points = list(STRIP) if base else [(0.0, 0.0, 0.0)] * 6
        sparse_points = {i: p for i, p in moved.items()}
        if not base:
            sparse_points.update({0: STRIP[0], 2: STRIP[2], 3: STRIP[3], 5: STRIP[5]})
            sparse_points[0] = (0.0, 0.0, -0.5)
        keys = sorted(sparse_points)
        indices_view = blob.view(struct.pack(f"<{len(keys)}H", *keys))
        values_view = blob.view(b"".join(struct.pack("<3f", *sparse_points[k]) for k in keys))
        final = [sparse_points.get(i, points[i]) for i in range(6)]
        accessor = {"componentType": 5126, "count": 6, "type": "VEC3",
                    "min": [min(p[k] for p in final) for k in range(3)],
                    "max": [max(p[k] for p in final) for k in range(3)],
                    "sparse": {"count": len(keys), "indices": {"bufferView": indices_view, "componentType": 5123},
                               "values": {"bufferView": values_view}}}
        if base:
            accessor["bufferView"] = blob.view(b"".join(struct.pack("<3f", *p) for p in points))
        position = blob.raw_accessor(accessor)
        primitive = {"attributes": {"POSITION": position}, "mode": 5}
        name = "gltf-sparse" + ("" if base else "-no-view")
        save_gltf(folder, f"{name}.glb", one_mesh(primitive), blob)
        case(folder, name, f"{name}.glb", "pygltflib", faces_of(final, triangles_of(5, 6)))
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    zeros = blob.raw_accessor({"componentType": 5126, "count": 6, "type": "VEC2"})
    document = textured(folder, {"POSITION": position, "TEXCOORD_0": zeros})
    save_gltf(folder, "gltf-no-view-uvs.glb", document, blob)
    triangles = triangles_of(5, 6)
    case(folder, "gltf-no-view-uvs", "gltf-no-view-uvs.glb", "pygltflib", faces_of(STRIP, triangles),
         uvs=[[[0.0, 0.0]] * 3 for _ in triangles])


def textured_square(folder, name, image, mime=None, where="view", texture=None, fallback=None, used=(), required=()):
    """The strip with `image` (image 0) as its base colour texture, in a GLB's view, a data URI
    or a file, shown through `texture` (by default its `source`); a PNG `fallback` is image 1."""
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    uvs = [(p[0] / 2, p[1]) for p in STRIP]
    texcoord = blob.accessor(uvs, "f", "VEC2")
    if where == "view":
        source = {"bufferView": blob.view(image), "mimeType": mime}
    elif where == "data":
        import base64
        source = {"uri": f"data:{mime};base64," + base64.b64encode(image).decode()}
    else:
        (folder / where).write_bytes(image)
        source = {"uri": where.replace(" ", "%20")}
    images = [source]
    if fallback is not None:
        images.append({"bufferView": blob.view(fallback), "mimeType": "image/png"})
    primitive = {"attributes": {"POSITION": position, "TEXCOORD_0": texcoord}, "mode": 5, "material": 0}
    document = one_mesh(primitive, materials=[{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
                        textures=[texture or {"source": 0}], images=images, extensionsUsed=list(used))
    file = f"{name}.glb" if where == "view" else f"{name}.gltf"
    save_gltf(folder, file, document, blob, required=required, embed=True)
    return file, faces_of(STRIP, triangles_of(5, 6))


def gltf_images(folder):
    for kind, image, texel in image_variants():
        name = f"gltf-image-{kind}"
        file, faces = textured_square(folder, name, image, "image/png")
        case(folder, name, file, "pygltflib", faces, texel={"x": 1, "y": 0, "rgb": list(texel)})
    for progressive in [False, True]:
        name = "gltf-image-jpeg" + ("-progressive" if progressive else "")
        file, faces = textured_square(folder, name, jpeg(progressive), "image/jpeg")
        case(folder, name, file, "pygltflib", faces, texel={"x": 3, "y": 3, "rgb": [180, 90, 40], "within": 4})
    rgb8 = image_variants()[0][1]
    file, faces = textured_square(folder, "gltf-image-data-uri", rgb8, "image/png", where="data")
    case(folder, "gltf-image-data-uri", file, "pygltflib", faces, texel={"x": 1, "y": 0, "rgb": TEXELS[0][1]})
    file, faces = textured_square(folder, "gltf-image-spaced-name", rgb8, where="my tiles.png")
    case(folder, "gltf-image-spaced-name", file, "pygltflib", faces, texel={"x": 1, "y": 0, "rgb": TEXELS[0][1]})
    # EXT_texture_webp (lossless WebP by Pillow): with a PNG fallback as the texture's own source
    # (other texels: read instead, the texel would differ), and alone (the extension required).
    webp = pillow_bytes(format="WEBP", lossless=True)
    inverted = png(2, 2, 2, 8, [[255 - c for rgb in row for c in rgb] for row in TEXELS])
    webp_texture = {"extensions": {"EXT_texture_webp": {"source": 0}}}
    file, faces = textured_square(folder, "gltf-image-webp", webp, "image/webp", texture={**webp_texture, "source": 1},
                                  fallback=inverted, used=["EXT_texture_webp"])
    case(folder, "gltf-image-webp", file, "Pillow", faces, texel={"x": 1, "y": 0, "rgb": TEXELS[0][1]})
    file, faces = textured_square(folder, "gltf-image-webp-only", webp, "image/webp", texture=webp_texture,
                                  required=["EXT_texture_webp"])
    case(folder, "gltf-image-webp-only", file, "Pillow", faces, texel={"x": 1, "y": 0, "rgb": TEXELS[0][1]})


def gltf_materials_and_nodes(folder):
    """A texture shared by two materials, a material without a texture, no material; a node
    matrix against TRS, a mesh placed twice, no default scene, no scenes."""
    (folder / "tiles.png").write_bytes(tiles_png())
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    texcoord = blob.accessor([(p[0] / 2, p[1]) for p in STRIP], "f", "VEC2")
    primitives = [{"attributes": {"POSITION": position, "TEXCOORD_0": texcoord}, "mode": 5, "material": m}
                  for m in range(3)] + [{"attributes": {"POSITION": position}, "mode": 5}]
    factors = [[1, 1, 1, 1], [0.2, 0.4, 0.6, 1], [0.3, 0.3, 0.05, 1]]
    materials = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": factors[0]}},
                 {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": factors[1]}},
                 {"pbrMetallicRoughness": {"baseColorFactor": factors[2]}}]
    nodes = [{"mesh": m, "translation": [0, 0, 2.0 * m]} for m in range(4)]
    document = {"scene": 0, "scenes": [{"nodes": [0, 1, 2, 3]}], "nodes": nodes,
                "meshes": [{"primitives": [p]} for p in primitives], "materials": materials,
                "textures": [{"source": 0}], "images": [{"uri": "tiles.png"}]}
    save_gltf(folder, "gltf-materials.gltf", document, blob)
    faces, colours = [], []
    for m in range(4):
        placed = node_world(STRIP, translation=(0, 0, 2.0 * m))
        triangles = triangles_of(5, 6)
        faces += faces_of(placed, triangles)
        colour = [srgb(f) for f in (factors[m][:3] if m < 3 else [1.0, 1.0, 1.0])]
        colours += [colour] * len(triangles)
    case(folder, "gltf-materials", "gltf-materials.gltf", "pygltflib", faces, colours=colours)

    # Matrix (column-major) against TRS: the same placement, and a mesh placed by both.
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    angle = 0.7
    c, s = math.cos(angle), math.sin(angle)
    matrix = [c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, 1, 2, 3, 1]
    quaternion = [0, 0, math.sin(angle / 2), math.cos(angle / 2)]
    document = {"scene": 0, "scenes": [{"nodes": [0, 1]}],
                "nodes": [{"mesh": 0, "matrix": matrix}, {"mesh": 0, "rotation": quaternion, "translation": [1, 2, 13]}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "mode": 5}]}]}
    save_gltf(folder, "gltf-matrix-trs.glb", document, blob)
    turned = [(c * x - s * y + 1, s * x + c * y + 2, z + 3) for x, y, z in STRIP]
    faces = faces_of(turned, triangles_of(5, 6)) + faces_of([(x, y, z + 10) for x, y, z in turned],
                                                           triangles_of(5, 6))
    case(folder, "gltf-matrix-trs", "gltf-matrix-trs.glb", "pygltflib", faces)

    # A mirroring node (negative determinant): the spec takes its triangles' front faces as
    # clockwise, so the faces keep their front by turning the other way.
    document = {"scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "scale": [-1, 1, 1]}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "mode": 5}]}]}
    save_gltf(folder, "gltf-mirrored.glb", document, blob)
    mirrored = [(-x, y, z) for x, y, z in STRIP]
    case(folder, "gltf-mirrored", "gltf-mirrored.glb", "pygltflib",
         faces_of(mirrored, [(a, c, b) for a, b, c in triangles_of(5, 6)]))

    # EXT_mesh_gpu_instancing (gltfpack -mi, gltf-transform instance): three instances, the
    # rotation a normalized i16 quaternion (a quarter turn about z), each after the node's TRS.
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    offsets = [(0.0, 0.0, 0.0), (5.0, 0.0, 0.0), (0.0, 5.0, 1.0)]
    half = int(round(math.sqrt(0.5) * 32767))
    turns = [(0, 0, 0, 32767), (0, 0, half, half), (0, 0, 0, 32767)]
    sizes = [(1.0, 1.0, 1.0), (1.0, 1.0, 1.0), (2.0, 2.0, 2.0)]
    attributes = {"TRANSLATION": blob.accessor(offsets, "f", "VEC3"),
                  "ROTATION": blob.accessor(turns, "h", "VEC4", normalized=True),
                  "SCALE": blob.accessor(sizes, "f", "VEC3")}
    document = {"scene": 0, "scenes": [{"nodes": [0]}],
                "nodes": [{"mesh": 0, "translation": [0, 0, 10],
                           "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "mode": 5}]}]}
    save_gltf(folder, "gltf-instancing.glb", document, blob, required=["EXT_mesh_gpu_instancing"])
    faces = []
    for offset, turn, size in zip(offsets, turns, sizes):
        z, w = turn[2] / 32767, turn[3] / 32767
        angle = 2 * math.atan2(z, w)
        c, s = math.cos(angle), math.sin(angle)
        placed = [(c * x * size[0] - s * y * size[1] + offset[0], s * x * size[0] + c * y * size[1] + offset[1],
                   z_ * size[2] + offset[2] + 10) for x, y, z_ in STRIP]
        faces += faces_of(placed, triangles_of(5, 6))
    case(folder, "gltf-instancing", "gltf-instancing.glb", "pygltflib", faces)

    # No `scene`: the first scene is shown (node 0), not node 1 of the second.
    document = {"scenes": [{"nodes": [0]}, {"nodes": [1]}],
                "nodes": [{"mesh": 0}, {"mesh": 0, "translation": [0, 0, 5]}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "mode": 5}]}]}
    save_gltf(folder, "gltf-no-default-scene.glb", document, blob)
    case(folder, "gltf-no-default-scene", "gltf-no-default-scene.glb", "pygltflib",
         faces_of(STRIP, triangles_of(5, 6)))

    # No scenes at all: the root nodes (no one's child) and their children, each once.
    document = {"nodes": [{"children": [1], "translation": [0, 0, 5]}, {"mesh": 0, "translation": [1, 0, 0]}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "mode": 5}]}]}
    save_gltf(folder, "gltf-no-scenes.glb", document, blob)
    case(folder, "gltf-no-scenes", "gltf-no-scenes.glb", "pygltflib",
         faces_of(node_world(STRIP, translation=(1, 0, 5)), triangles_of(5, 6)))


def gltf_refused(folder):
    """What omnisim cannot show: refused by name."""
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    for extension in ["EXT_meshopt_compression", "KHR_draco_mesh_compression", "KHR_texture_basisu"]:
        name = f"gltf-refused-{extension}"
        save_gltf(folder, f"{name}.glb", one_mesh({"attributes": {"POSITION": position}, "mode": 5}), blob,
                  required=[extension])
        case(folder, name, f"{name}.glb", "pygltflib", refuse=[extension])
    for mode, word in [(0, "Points"), (1, "Lines"), (3, "LineStrip")]:
        name = f"gltf-refused-mode-{mode}"
        save_gltf(folder, f"{name}.glb", one_mesh({"attributes": {"POSITION": position}, "mode": mode}), blob)
        case(folder, name, f"{name}.glb", "pygltflib", refuse=[word, "triangle"])


def gltf_bad(folder):
    """Files that lie or break the spec: a located error each, no panic, no huge allocation."""
    def bad(name, words, primitive_of, required=()):
        blob = Blob()
        save_gltf(folder, f"{name}.glb", one_mesh(primitive_of(blob)), blob, required=required)
        case(folder, name, f"{name}.glb", "pygltflib", refuse=words)

    def sparse_positions(blob, index, values_length):
        values = blob.view(struct.pack("<3f", 1, 2, 3)[:values_length])
        position = blob.raw_accessor({
            "bufferView": blob.view(b"".join(struct.pack("<3f", *p) for p in STRIP)), "componentType": 5126,
            "count": 6, "type": "VEC3", "min": [0, 0, 0], "max": [3, 3, 3],
            "sparse": {"count": 1, "indices": {"bufferView": blob.view(struct.pack("<H", index)), "componentType": 5123},
                       "values": {"bufferView": values}}})
        return {"attributes": {"POSITION": position}, "mode": 5}

    bad("gltf-bad-sparse-index", ["accessor 0 (POSITION)", "sparse index 9 is out of range"],
        lambda blob: sparse_positions(blob, 9, 12))
    bad("gltf-bad-sparse-truncated", ["accessor 0 (POSITION)", "reach beyond"], lambda blob: sparse_positions(blob, 1, 8))
    bad("gltf-bad-huge-view-less", ["accessor 0 (POSITION)", "4000000000 elements"], lambda blob: {
        "attributes": {"POSITION": blob.raw_accessor({"componentType": 5126, "count": 4000000000, "type": "VEC3",
                                                      "min": [0, 0, 0], "max": [0, 0, 0]})},
        "indices": blob.accessor([(0,), (1,), (2,)], "B", "SCALAR")})
    bad("gltf-bad-view-less-past-the-file", ["accessor 0 (POSITION)", "no buffer view and 100000000 elements"],
        lambda blob: {"attributes": {"POSITION": blob.raw_accessor({
            "componentType": 5126, "count": 100000000, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]})}})
    # gltf-json's validation indexed the accessors with this unchecked (a panic in the base).
    bad("gltf-bad-position-accessor", ["mesh 0 primitive 0", "names accessor 9"], lambda blob: {
        "attributes": {"POSITION": 9, "NORMAL": blob.accessor(STRIP, "f", "VEC3")}})
    bad("gltf-bad-float-indices", ["accessor 1 (indices)", "unsigned"], lambda blob: {
        "attributes": {"POSITION": blob.accessor(STRIP, "f", "VEC3", minmax=True)},
        "indices": blob.accessor([(0.0,), (1.0,), (2.0,)], "f", "SCALAR")})
    bad("gltf-bad-colour-vec2", ["accessor 1 (COLOR_0)", "VEC3 or VEC4"], lambda blob: {
        "attributes": {"POSITION": blob.accessor(STRIP, "f", "VEC3", minmax=True),
                       "COLOR_0": blob.accessor([(0.5, 0.5)] * 6, "f", "VEC2")}, "mode": 5})
    bad("gltf-bad-short-strip", ["TriangleStrip has 2 vertices", "3 or more"], lambda blob: {
        "attributes": {"POSITION": blob.accessor(STRIP[:2], "f", "VEC3", minmax=True)}, "mode": 5})
    bad("gltf-bad-positions-truncated", ["accessor 0 (POSITION)", "truncated"], lambda blob: {
        "attributes": {"POSITION": blob.raw_accessor({"bufferView": blob.view(b"\0" * 40), "componentType": 5126,
                                                      "count": 6, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]})},
        "mode": 5})
    # i8 texture coordinates are KHR_mesh_quantization's (gltf's reader reached `unreachable!`).
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    quantized = [(int(round(p[0] / 2 * 127)), -int(round(p[1] * 127))) for p in STRIP]
    texcoord = blob.accessor(quantized, "b", "VEC2", normalized=True, stride=4)
    document = textured(folder, {"POSITION": position, "TEXCOORD_0": texcoord})
    save_gltf(folder, "gltf-quantized-uv-i8.glb", document, blob, required=["KHR_mesh_quantization"])
    uvs = [(dequantize(u, "b", True), dequantize(v, "b", True)) for u, v in quantized]
    case(folder, "gltf-quantized-uv-i8", "gltf-quantized-uv-i8.glb", "pygltflib", faces_of(STRIP, triangles_of(5, 6)),
         uvs=[[list(uvs[i]) for i in t] for t in triangles_of(5, 6)])
    # A URI whose % escape is broken.
    blob = Blob()
    position = blob.accessor(STRIP, "f", "VEC3", minmax=True)
    texcoord = blob.accessor([(0.0, 0.0)] * 6, "f", "VEC2")
    document = textured(folder, {"POSITION": position, "TEXCOORD_0": texcoord}, uri="tiles%zz.png")
    save_gltf(folder, "gltf-bad-percent.gltf", document, blob)
    case(folder, "gltf-bad-percent", "gltf-bad-percent.gltf", "pygltflib", refuse=["tiles%zz.png", "hexadecimal"])


def trimesh_files(folder):
    """trimesh's own GLB (textured; vertex-coloured) and PLY (face colours)."""
    vertices = np.array(STRIP, dtype=np.float64)
    faces = np.array([(0, 1, 2), (2, 1, 3), (2, 3, 4), (4, 3, 5)])
    uv = np.array([(p[0] / 2, p[1]) for p in STRIP])
    texture = Image.new("RGB", (2, 2))
    texture.putdata([rgb for row in TEXELS for rgb in row])
    mesh = trimesh.Trimesh(vertices, faces, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, image=texture))
    mesh.export(str(folder / "trimesh-textured.glb"))
    # trimesh's glTF is y up like any glTF: the file's coordinates are the mesh's.
    case(folder, "trimesh-textured-glb", "trimesh-textured.glb", "trimesh", faces_of(STRIP, faces.tolist()),
         uvs=[[[uv[i][0], 1 - uv[i][1]] for i in t] for t in faces.tolist()],
         texel={"x": 1, "y": 0, "rgb": list(TEXELS[0][1])})
    colours = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [255, 255, 0, 255],
                        [0, 255, 255, 255], [128, 64, 32, 255]], dtype=np.uint8)
    mesh = trimesh.Trimesh(vertices, faces, vertex_colors=colours, process=False)
    mesh.export(str(folder / "trimesh-colours.glb"))
    # glTF's COLOR_0 is linear (spec 3.7.2.1); trimesh stores its colour bytes as they are.
    case(folder, "trimesh-colours-glb", "trimesh-colours.glb", "trimesh", faces_of(STRIP, faces.tolist()),
         corner_colours=[[[srgb(c / 255) for c in colours[i][:3]] for i in t] for t in faces.tolist()])
    face_colours = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [9, 99, 199, 255]],
                            dtype=np.uint8)
    mesh = trimesh.Trimesh(vertices, faces, face_colors=face_colours, process=False)
    mesh.export(str(folder / "trimesh-face-colours.ply"))
    case(folder, "trimesh-face-colours-ply", "trimesh-face-colours.ply", "trimesh", faces_of(STRIP, faces.tolist()),
         colours=[c[:3].tolist() for c in face_colours])


# ---------------------------------------------------------------- PLY through plyfile and Open3D

def ply_files(folder):
    points = STRIP
    polygons = [[0, 2, 3, 1], [2, 4, 5, 3]]  # two quads
    fan = lambda poly: [(poly[0], poly[k], poly[k + 1]) for k in range(1, len(poly) - 1)]
    expected = faces_of(points, [t for poly in polygons for t in fan(poly)])
    for encoding, text, byte_order in [("ascii", True, "="), ("little", False, "<"), ("big", False, ">")]:
        for coordinate in ["f4", "f8"]:
            for count_type, index_type in [("u1", "i4"), ("u1", "u4"), ("u2", "u2"), ("i4", "i4"), ("u1", "u1")]:
                for name_of_list in ["vertex_indices", "vertex_index"]:
                    if coordinate == "f8" and (count_type, index_type) != ("u1", "i4"):
                        continue
                    if name_of_list == "vertex_index" and (coordinate, count_type, index_type) != ("f4", "u1", "i4"):
                        continue
                    vertex = np.array([tuple(p) for p in points], dtype=[("x", coordinate), ("y", coordinate),
                                                                         ("z", coordinate)])
                    face = np.empty(len(polygons), dtype=[(name_of_list, index_type, (4,))])
                    face[name_of_list] = polygons
                    data = plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"),
                                            plyfile.PlyElement.describe(face, "face",
                                                                        len_types={name_of_list: count_type})],
                                           text=text, byte_order=byte_order)
                    name = f"ply-{encoding}-{coordinate}-{count_type}-{index_type}-{name_of_list}"
                    data.write(str(folder / f"{name}.ply"))
                    case(folder, name, f"{name}.ply", "plyfile", expected)
    # A pentagon, fan-triangulated around its first corner.
    ring = [(0, 0, 0), (1, 0, 0), (1.5, 1, 0.1), (0.5, 1.8, 0.2), (-0.5, 1, 0.3)]
    vertex = np.array(ring, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    face = np.empty(1, dtype=[("vertex_indices", "i4", (5,))])
    face["vertex_indices"] = [[0, 1, 2, 3, 4]]
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(face, "face")]).write(
        str(folder / "ply-pentagon.ply"))
    case(folder, "ply-pentagon", "ply-pentagon.ply", "plyfile", faces_of(ring, fan([0, 1, 2, 3, 4])))
    triangles = [(0, 1, 2), (2, 1, 3), (2, 3, 4), (4, 3, 5)]
    rgb = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (0, 255, 255), (128, 64, 32)]
    # Colours as uchar with alpha (ScanNet's layout), as float in [0, 1], and with double coordinates.
    for name, colour_type, scale, alpha in [("ply-scannet", "u1", 1, True), ("ply-float-colours", "f4", 1 / 255, False),
                                            ("ply-double-colours", "f8", 1 / 255, True)]:
        fields = [("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", colour_type), ("green", colour_type),
                  ("blue", colour_type)] + ([("alpha", colour_type)] if alpha else [])
        vertex = np.array([(*p, *[c * scale for c in rgb[i]], *([255 * scale] if alpha else []))
                           for i, p in enumerate(points)], dtype=fields)
        face = np.empty(len(triangles), dtype=[("vertex_indices", "i4", (3,))])
        face["vertex_indices"] = triangles
        plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(face, "face")],
                        comments=["VCGLIB generated"] if alpha else []).write(str(folder / f"{name}.ply"))
        case(folder, name, f"{name}.ply", "plyfile", faces_of(points, triangles),
             corner_colours=[[list(rgb[i]) for i in t] for t in triangles])
    # Matterport/MeshLab: per-face texcoord lists and `comment TextureFile`; texnumber picks the file.
    (folder / "tiles.png").write_bytes(tiles_png())
    vertex = np.array([tuple(p) for p in points], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    face = np.empty(len(triangles), dtype=[("vertex_indices", "i4", (3,)), ("texcoord", "f4", (6,)),
                                           ("texnumber", "i4")])
    face["vertex_indices"] = triangles
    face["texcoord"] = [[c for i in t for c in (points[i][0] / 2, points[i][1])] for t in triangles]
    face["texnumber"] = 0
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(face, "face")],
                    comments=["TextureFile tiles.png"]).write(str(folder / "ply-texcoord.ply"))
    uvs = [[[float(np.float32(points[i][0] / 2)), 1 - points[i][1]] for i in t] for t in triangles]
    case(folder, "ply-texcoord", "ply-texcoord.ply", "plyfile", faces_of(points, triangles), uvs=uvs,
         texel={"x": 1, "y": 0, "rgb": list(TEXELS[0][1])})
    # The same with the texture as TGA (uncompressed and RLE) and BMP, written by Pillow.
    for kind, extension, save in SCAN_IMAGES:
        tiles_image().save(folder / f"tiles-{kind}.{extension}", **save)
        name = f"ply-texture-{kind}"
        plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(face, "face")],
                        comments=[f"TextureFile tiles-{kind}.{extension}"]).write(str(folder / f"{name}.ply"))
        case(folder, name, f"{name}.ply", "Pillow", faces_of(points, triangles), uvs=uvs,
             texel={"x": 1, "y": 0, "rgb": list(TEXELS[0][1])})
    # The PLY type names of the 2012 spec (float32, uint8, int32), another element before the
    # faces, extra face properties, and Windows line ends in an ASCII file.
    header = ["ply", "format ascii 1.0", "comment written by hand", "obj_info aliases", "element vertex 6",
              "property float32 x", "property float32 y", "property float32 z", "element material 1",
              "property uint8 index", "element face 2", "property list uint8 int32 vertex_indices",
              "property int32 segment_id", "end_header"]
    body = [" ".join(str(c) for c in p) for p in points] + ["0", "4 0 2 3 1 7", "4 2 4 5 3 8"]
    (folder / "ply-type-aliases.ply").write_bytes("\r\n".join(header + body).encode() + b"\r\n")
    case(folder, "ply-type-aliases", "ply-type-aliases.ply", "hand", expected)
    # Open3D's writer (ASCII and binary), vertex colours and normals.
    mesh = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(np.array(points, dtype=np.float64)),
                                     o3d.utility.Vector3iVector(np.array(triangles, dtype=np.int32)))
    mesh.vertex_colors = o3d.utility.Vector3dVector(np.array(rgb, dtype=np.float64) / 255)
    mesh.compute_vertex_normals()
    for ascii_ in [True, False]:
        name = "ply-open3d-" + ("ascii" if ascii_ else "binary")
        o3d.io.write_triangle_mesh(str(folder / f"{name}.ply"), mesh, write_ascii=ascii_)
        case(folder, name, f"{name}.ply", "open3d", faces_of(points, triangles),
             corner_colours=[[list(rgb[i]) for i in t] for t in triangles])


# ---------------------------------------------------------------- OBJ and MTL by hand

def obj_files(folder):
    (folder / "tiles.png").write_bytes(tiles_png())
    (folder / "sub").mkdir(exist_ok=True)
    (folder / "sub" / "tiles.png").write_bytes((folder / "tiles.png").read_bytes())
    (folder / "my tiles.png").write_bytes((folder / "tiles.png").read_bytes())
    points = STRIP
    uv = [(p[0] / 2, p[1]) for p in points]
    vertices = "".join(f"v {x} {y} {z}\n" for x, y, z in points) + "".join(f"vt {u} {v}\n" for u, v in uv)
    quads = [[0, 2, 3, 1], [2, 4, 5, 3]]
    fan = [(q[0], q[k], q[k + 1]) for q in quads for k in (1, 2)]
    textured = dict(uvs=[[[uv[i][0], 1 - uv[i][1]] for i in t] for t in fan],
                    texel={"x": 1, "y": 0, "rgb": list(TEXELS[0][1])})

    def obj(name, faces_text, mtl=None, extra="", usemtl="tiles", vt=None):
        text = (f"mtllib {name}.mtl\n" if mtl is not None else "") + (vt or vertices) + extra
        text += (f"usemtl {usemtl}\n" if usemtl else "") + faces_text
        (folder / f"{name}.obj").write_text(text)
        if mtl is not None:
            (folder / f"{name}.mtl").write_text(mtl)

    positive = "".join("f " + " ".join(f"{i + 1}/{i + 1}" for i in q) + "\n" for q in quads)
    negative = "".join("f " + " ".join(f"{i - 6}/{i - 6}" for i in q) + "\n" for q in quads)
    plain_mtl = "newmtl tiles\nKd 1 1 1\nmap_Kd tiles.png\n"
    obj("obj-quads", positive, plain_mtl)
    case(folder, "obj-quads", "obj-quads.obj", "hand", faces_of(points, fan), **textured)
    obj("obj-negative", negative, plain_mtl)
    case(folder, "obj-negative", "obj-negative.obj", "hand", faces_of(points, fan), **textured)
    ring = [0, 2, 5, 3, 1]  # a pentagon whose fan around its first corner has no flat triangle
    obj("obj-ngon", "f " + " ".join(f"{i + 1}" for i in ring) + "\n", None, usemtl=None)
    case(folder, "obj-ngon", "obj-ngon.obj", "hand",
         faces_of(points, [(ring[0], ring[k], ring[k + 1]) for k in range(1, len(ring) - 1)]))
    vt3 = "".join(f"v {x} {y} {z}\n" for x, y, z in points) + "".join(f"vt {u} {v} 0\n" for u, v in uv)
    obj("obj-vt3", positive, plain_mtl, vt=vt3)
    case(folder, "obj-vt3", "obj-vt3.obj", "hand", faces_of(points, fan), **textured)
    obj("obj-usemtl-without-mtllib", positive, None)
    case(folder, "obj-usemtl-without-mtllib", "obj-usemtl-without-mtllib.obj", "hand", faces_of(points, fan))
    for label, line in [("scale", "map_Kd -s 2 2 1 tiles.png"), ("offset", "map_Kd -o 0.5 0.25 0 tiles.png"),
                        ("clamp", "map_Kd -clamp on tiles.png"), ("bm", "map_Kd -bm 0.5 tiles.png"),
                        ("backslash", "map_Kd sub\\tiles.png"), ("spaces", "map_Kd my tiles.png")]:
        name = f"obj-map-{label}"
        obj(name, positive, f"newmtl tiles\nKd 1 1 1\n{line}\n")
        uvs = textured["uvs"]
        if label == "scale":
            uvs = [[[2 * u, 1 - 2 * (1 - v)] for u, v in t] for t in uvs]
        if label == "offset":
            uvs = [[[u + 0.5, 1 - ((1 - v) + 0.25)] for u, v in t] for t in uvs]
        case(folder, name, f"{name}.obj", "hand", faces_of(points, fan), uvs=uvs, texel=textured["texel"])
    obj("obj-no-kd", positive, "newmtl tiles\nmap_Kd tiles.png\n")
    case(folder, "obj-no-kd", "obj-no-kd.obj", "hand", faces_of(points, fan), colours=[[255, 255, 255]] * 4,
         **textured)
    obj("obj-kd-only", positive, "newmtl tiles\nKd 0.2 0.4 0.6\n")
    case(folder, "obj-kd-only", "obj-kd-only.obj", "hand", faces_of(points, fan),
         colours=[[srgb(0.2), srgb(0.4), srgb(0.6)]] * 4)
    # Windows line ends in the OBJ and its MTL, and an MTL file name with a space.
    (folder / "obj crlf.mtl").write_bytes(plain_mtl.replace("\n", "\r\n").encode())
    text = "mtllib obj crlf.mtl\n" + vertices + "usemtl tiles\n" + positive
    (folder / "obj-crlf.obj").write_bytes(text.replace("\n", "\r\n").encode())
    case(folder, "obj-crlf", "obj-crlf.obj", "hand", faces_of(points, fan), **textured)
    # `Kd r` stands for `Kd r r r` (tobj panicked on it); two numbers are refused.
    obj("obj-kd-one-number", positive, "newmtl tiles\nKd 0.5\n")
    case(folder, "obj-kd-one-number", "obj-kd-one-number.obj", "hand", faces_of(points, fan),
         colours=[[srgb(0.5)] * 3] * 4)
    obj("obj-bad-kd-two-numbers", positive, "newmtl tiles\nKd 0.5 0.25\n")
    case(folder, "obj-bad-kd-two-numbers", "obj-bad-kd-two-numbers.obj", "hand",
         refuse=["line 2", "Kd needs one number (grey) or three"])
    # A face index far past any mesh: refused naming its line (mtllib, 6 v, 6 vt, usemtl, 2 faces before it).
    obj("obj-bad-face-index", positive + "f 1/1 2/2 3/4611686018427387904\n", plain_mtl)
    case(folder, "obj-bad-face-index", "obj-bad-face-index.obj", "hand",
         refuse=["obj-bad-face-index.obj", "line 17: face index 4611686018427387904 names no texture coordinate",
                 "the file has 6 texture coordinates"])
    # map_Kd as TGA (uncompressed and RLE) and BMP, written by Pillow; each cut short, refused.
    for kind, extension, save in SCAN_IMAGES:
        image = pillow_bytes(**save)
        (folder / f"tiles-{kind}.{extension}").write_bytes(image)
        (folder / f"tiles-{kind}-cut.{extension}").write_bytes(image[:len(image) // 2])
        for cut in ["", "-cut"]:
            name = f"obj-image-{kind}{cut}"
            obj(name, positive, f"newmtl tiles\nKd 1 1 1\nmap_Kd tiles-{kind}{cut}.{extension}\n")
            if cut:
                case(folder, name, f"{name}.obj", "Pillow",
                     refuse=[f"tiles-{kind}-cut.{extension}", f"not a readable {extension.upper()} image"])
            else:
                case(folder, name, f"{name}.obj", "Pillow", faces_of(points, fan), **textured)
    obj("obj-missing-texture", positive, "newmtl tiles\nKd 1 1 1\nmap_Kd absent.png\n")
    case(folder, "obj-missing-texture", "obj-missing-texture.obj", "hand", refuse=["absent.png", "not found"])
    obj("obj-unknown-map-option", positive, "newmtl tiles\nKd 1 1 1\nmap_Kd -zoom 2 tiles.png\n")
    case(folder, "obj-unknown-map-option", "obj-unknown-map-option.obj", "hand", refuse=["-zoom", "no option"])
    obj("obj-map-option-without-value", positive, "newmtl tiles\nKd 1 1 1\nmap_Kd -s tiles.png\n")
    case(folder, "obj-map-option-without-value", "obj-map-option-without-value.obj", "hand",
         refuse=["-s", "lacks its value"])


def main(folder):
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for writer in [gltf_topology, gltf_interleaved, gltf_quantization, gltf_colours, gltf_texcoord_sets,
                   gltf_sparse_and_viewless, gltf_images, gltf_materials_and_nodes, gltf_refused, gltf_bad,
                   trimesh_files,
                   ply_files, obj_files]:
        writer(folder)
    (folder / "cases.json").write_text(json.dumps(CASES, indent=1))
    print(f"{len(CASES)} cases in {folder}")


if __name__ == "__main__":
    main(sys.argv[1])
