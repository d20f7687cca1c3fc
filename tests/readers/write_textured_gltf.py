"""Writes a textured square as glTF with pygltflib, an independent writer, for omnisim to read
(tests/tests/textures.rs, `a_gltf_and_a_glb_written_by_pygltflib_map_their_texture_exactly`).

    python tests/readers/write_textured_gltf.py FOLDER

FOLDER holds the test's `tiles.png` (4×3 texels). Written: `square.gltf` with its geometry in
an external `square.bin` and the texture by URI, and `square.glb`, the same with buffer and
image inside (the image as a `data:` URI). The square is 2 m × 1.5 m in its mesh's xy plane; a parent node (translation
(2, 0, 0), scale 2) and a child (a rotation taking local x to world −y, y to z, z to −x, and
scale ½) stand it at x = 2 facing the origin. UV (0, 0) is its corner at local (−1, 0.75),
the texture stretched over it once, clamped (the test's closed form).
"""
import math
import os
import struct
import sys

import pygltflib
from pygltflib import (GLTF2, Accessor, Asset, Buffer, BufferView, Image, Material, Mesh, Node,
                       PbrMetallicRoughness, Primitive, Sampler, Scene, Texture, TextureInfo)


def quaternion_of(columns):
    """(x, y, z, w) of the rotation matrix with these columns (Shepperd's method, trace > 0)."""
    (m00, m10, m20), (m01, m11, m21), (m02, m12, m22) = columns
    trace = m00 + m11 + m22
    assert trace > -1.0 + 1e-9, "the test's rotation has a positive trace term"
    w = math.sqrt(1.0 + trace) / 2.0
    return [(m21 - m12) / (4 * w), (m02 - m20) / (4 * w), (m10 - m01) / (4 * w), w]


def main(folder):
    corners = [(-1.0, 0.75, 0.0), (-1.0, -0.75, 0.0), (1.0, -0.75, 0.0), (1.0, 0.75, 0.0)]
    uvs = [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]
    indices = [0, 1, 2, 0, 2, 3]
    positions = b"".join(struct.pack("<3f", *c) for c in corners)
    coordinates = b"".join(struct.pack("<2f", *uv) for uv in uvs)
    triangles = struct.pack("<6H", *indices)
    blob = positions + coordinates + triangles
    # Local x → world −y, y → z, z → −x.
    rotation = quaternion_of([(0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (-1.0, 0.0, 0.0)])
    gltf = GLTF2(
        asset=Asset(version="2.0", generator="pygltflib (omnisim reader test)"),
        scene=0,
        scenes=[Scene(nodes=[0])],
        nodes=[
            Node(children=[1], translation=[2.0, 0.0, 0.0], scale=[2.0, 2.0, 2.0]),
            Node(mesh=0, rotation=rotation, scale=[0.5, 0.5, 0.5]),
        ],
        meshes=[Mesh(primitives=[Primitive(attributes=pygltflib.Attributes(POSITION=0, TEXCOORD_0=1),
                                           indices=2, material=0)])],
        materials=[Material(pbrMetallicRoughness=PbrMetallicRoughness(baseColorTexture=TextureInfo(index=0)))],
        textures=[Texture(source=0, sampler=0)],
        samplers=[Sampler(wrapS=pygltflib.CLAMP_TO_EDGE, wrapT=pygltflib.CLAMP_TO_EDGE)],
        images=[Image(uri="tiles.png")],
        accessors=[
            Accessor(bufferView=0, componentType=pygltflib.FLOAT, count=4, type=pygltflib.VEC3,
                     min=[-1.0, -0.75, 0.0], max=[1.0, 0.75, 0.0]),
            Accessor(bufferView=1, componentType=pygltflib.FLOAT, count=4, type=pygltflib.VEC2),
            Accessor(bufferView=2, componentType=pygltflib.UNSIGNED_SHORT, count=6, type=pygltflib.SCALAR),
        ],
        bufferViews=[
            BufferView(buffer=0, byteOffset=0, byteLength=len(positions), target=pygltflib.ARRAY_BUFFER),
            BufferView(buffer=0, byteOffset=len(positions), byteLength=len(coordinates), target=pygltflib.ARRAY_BUFFER),
            BufferView(buffer=0, byteOffset=len(positions) + len(coordinates), byteLength=len(triangles),
                       target=pygltflib.ELEMENT_ARRAY_BUFFER),
        ],
        buffers=[Buffer(uri="square.bin", byteLength=len(blob))],
    )
    with open(os.path.join(folder, "square.bin"), "wb") as f:
        f.write(blob)
    gltf.save(os.path.join(folder, "square.gltf"))
    # The same file as one GLB: the buffer as its binary chunk, the image as a data URI
    # (pygltflib cannot move an image into a buffer view).
    glb = GLTF2().load(os.path.join(folder, "square.gltf"))
    glb.convert_images(pygltflib.ImageFormat.DATAURI)
    glb.convert_buffers(pygltflib.BufferFormat.BINARYBLOB)
    glb.save_binary(os.path.join(folder, "square.glb"))
    print("wrote square.gltf, square.bin, square.glb")


if __name__ == "__main__":
    import warnings

    # pygltflib warns that square.bin is left beside the GLB: it is meant to be.
    warnings.simplefilter("ignore", UserWarning)
    main(sys.argv[1])
