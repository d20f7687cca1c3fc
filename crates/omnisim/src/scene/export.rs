//! Writes the triangulated scene so other tools (`Open3D`, `CloudCompare`, `MeshLab`, Blender) load
//! exactly the geometry omnisim traces, with each face's colour on its corners.

use std::io::Write;
use std::path::Path;

use super::{Scene, SceneError};
use crate::atomic_file::write_atomically;

/// File formats `Scene::export` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// Binary little-endian PLY: float x y z, uchar red green blue per vertex; int face lists.
    Ply,
    /// Wavefront OBJ with the common `v x y z r g b` vertex-colour extension, one `o` per object.
    Obj,
}

/// The words an export's first lines name it by (after `comment ` in PLY, `# ` in OBJ).
const SIGNATURE: &str = "omnisim scene '";

impl ExportFormat {
    /// Whether a file's first bytes are those of a scene export in this format, so that a new
    /// export may replace it where it would not replace a user's own mesh.
    pub fn wrote(self, start: &[u8]) -> bool {
        match self {
            Self::Ply => {
                start.starts_with(format!("ply\nformat binary_little_endian 1.0\ncomment {SIGNATURE}").as_bytes())
            }
            Self::Obj => start.starts_with(format!("# {SIGNATURE}").as_bytes()),
        }
    }

    /// The format a file name asks for by its extension (`.ply`, `.obj`), if any.
    pub fn from_path(path: &Path) -> Option<Self> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "ply" => Some(Self::Ply),
            "obj" => Some(Self::Obj),
            _ => None,
        }
    }
}

pub(super) fn export(scene: &Scene, path: &Path, format: ExportFormat) -> Result<(), SceneError> {
    let triangles = scene.triangulate();
    write_atomically(path, |out| {
        match format {
            ExportFormat::Ply => {
                // Corners are not shared: a vertex takes the colour of its face.
                write!(
                    out,
                    "ply\nformat binary_little_endian 1.0\ncomment {SIGNATURE}{}', metres, z up\n\
                     element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
                     property uchar red\nproperty uchar green\nproperty uchar blue\n\
                     element face {}\nproperty list uchar int vertex_indices\nend_header\n",
                    scene.name.replace(['\n', '\r'], " "),
                    triangles.len() * 3,
                    triangles.len()
                )?;
                for (corners, face) in triangles.corners.iter().zip(&triangles.face) {
                    let colour = scene.faces[*face as usize].colour;
                    for c in corners {
                        for v in [c.x, c.y, c.z] {
                            out.write_all(&(v as f32).to_le_bytes())?;
                        }
                        out.write_all(&colour)?;
                    }
                }
                for i in 0..triangles.len() as i32 {
                    out.write_all(&[3])?;
                    for k in 0..3 {
                        out.write_all(&(3 * i + k).to_le_bytes())?;
                    }
                }
            }
            ExportFormat::Obj => {
                writeln!(
                    out,
                    "# {SIGNATURE}{}', metres, z up; v x y z r g b (colours 0-1)",
                    scene.name.replace(['\n', '\r'], " ")
                )?;
                let mut current_object = u32::MAX;
                for (i, (corners, face)) in triangles.corners.iter().zip(&triangles.face).enumerate() {
                    let face = &scene.faces[*face as usize];
                    if face.object != current_object {
                        current_object = face.object;
                        writeln!(
                            out,
                            "o {}",
                            scene.objects[face.object as usize]
                                .name
                                .replace(char::is_whitespace, "_")
                        )?;
                    }
                    let [r, g, b] = face.colour.map(|c| f64::from(c) / 255.0);
                    for c in corners {
                        writeln!(out, "v {} {} {} {r:.6} {g:.6} {b:.6}", c.x, c.y, c.z)?;
                    }
                    writeln!(out, "f {} {} {}", 3 * i + 1, 3 * i + 2, 3 * i + 3)?;
                }
            }
        }
        Ok(())
    })
    .map_err(|source| SceneError::Write {
        path: path.to_path_buf(),
        source,
    })
}
