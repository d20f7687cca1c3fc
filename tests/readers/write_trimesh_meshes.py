"""Writes meshes with trimesh, an independent writer, for omnisim to read
(tests/tests/textures.rs, `an_obj_and_a_ply_written_by_trimesh_keep_their_uvs_and_colours`).

    python tests/readers/write_trimesh_meshes.py FOLDER

FOLDER holds the test's `tiles.png` (4×3 texels). Written:
- `square.obj` with its MTL and texture (trimesh names them `material.mtl`, `material_0.png`):
  the 2 m × 1.5 m square at x = 2 facing the origin, its corners (2, 1, 0.75), (2, 1, −0.75),
  (2, −1, −0.75), (2, −1, 0.75) at UV (0, 1), (0, 0), (1, 0), (1, 1) (v up, as OBJ has it),
  the texture stretched over it once, diffuse colour white;
- `fan.ply` (binary, trimesh's default): the triangle (2, 1, −0.75), (2, −1, −0.75), (2, 0, 0.75)
  with vertex colours red, green, blue.
"""
import os
import sys

import numpy as np
import PIL.Image
import trimesh


def main(folder):
    corners = np.array([[2.0, 1.0, 0.75], [2.0, 1.0, -0.75], [2.0, -1.0, -0.75], [2.0, -1.0, 0.75]])
    uvs = np.array([[0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    square = trimesh.Trimesh(corners, [[0, 1, 2], [0, 2, 3]], process=False)
    image = PIL.Image.open(os.path.join(folder, "tiles.png"))
    material = trimesh.visual.material.SimpleMaterial(image=image, diffuse=[255, 255, 255, 255])
    square.visual = trimesh.visual.TextureVisuals(uv=uvs, image=image, material=material)
    square.export(os.path.join(folder, "square.obj"))

    fan = trimesh.Trimesh(
        [[2.0, 1.0, -0.75], [2.0, -1.0, -0.75], [2.0, 0.0, 0.75]],
        [[0, 1, 2]],
        vertex_colors=np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255]], dtype=np.uint8),
        process=False,
    )
    fan.export(os.path.join(folder, "fan.ply"))


if __name__ == "__main__":
    main(sys.argv[1])
