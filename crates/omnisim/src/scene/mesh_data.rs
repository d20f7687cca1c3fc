//! The triangles a mesh reader fills (`mesh.rs` for PLY, `obj.rs`, `gltf/`) and what they share
//! (the texture lookup beside the mesh file, v-up coordinates, mean colours), apart from the
//! dispatch in `mesh.rs` so that the readers need not import the module that calls them.

use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};

use super::lighting::srgb_to_linear;
use super::surface::{ColourMap, Surface, UvMap, gradient};
use super::texture::Wrap;
use super::texture_bank::TextureBank;

/// One triangle of a mesh, in the mesh file's own coordinates.
#[derive(Clone)]
pub(super) struct MeshTriangle {
    pub vertices: [DVec3; 3],
    /// Face colour from the file (face colour, else the mean of vertex colours), if any.
    pub colour: Option<[u8; 3]>,
    /// Texture (index in the scene's texture bank), wrap and corner (u, v), v down.
    pub texture: Option<CornerUvs>,
    /// sRGB vertex colours, interpolated across the triangle (in linear light).
    pub corner_colours: Option<[[u8; 3]; 3]>,
    /// Drawn in its albedo whatever the lights (glTF's `KHR_materials_unlit`).
    pub unlit: bool,
}

/// A mesh triangle's texture coordinates.
#[derive(Clone)]
pub(super) struct CornerUvs {
    pub texture: u32,
    pub wrap: [Wrap; 2],
    pub uv: [DVec2; 3],
}

impl MeshTriangle {
    /// Turns the triangle the other way round (its corners 1 and 2, with their texture
    /// coordinates and colours, swapped).
    pub(super) fn reverse_winding(&mut self) {
        self.vertices.swap(1, 2);
        if let Some(texture) = &mut self.texture {
            texture.uv.swap(1, 2);
        }
        if let Some(colours) = &mut self.corner_colours {
            colours.swap(1, 2);
        }
    }

    /// Whether [`MeshTriangle::surface`] can give this triangle a surface: a texture, vertex
    /// colours or an unlit material.
    pub(super) fn carries_surface(&self) -> bool {
        self.texture.is_some() || self.corner_colours.is_some() || self.unlit
    }

    /// The surface of this triangle once placed at `world` corners; `None` without texture or
    /// vertex colours (or for a triangle without area, which is dropped anyway).
    pub(super) fn surface(&self, world: &[DVec3]) -> Option<Surface> {
        if !self.carries_surface() {
            return None;
        }
        let corners = [world[0], world[1], world[2]];
        let affine = |values: [f64; 3]| gradient(corners, values).map(|g| (values[0], g));
        let uv = match &self.texture {
            None => None,
            Some(t) => {
                let (u0, gu) = affine(t.uv.map(|uv| uv.x))?;
                let (v0, gv) = affine(t.uv.map(|uv| uv.y))?;
                Some(UvMap {
                    texture: t.texture,
                    wrap: t.wrap,
                    at_anchor: DVec2::new(u0, v0),
                    gradient: [gu, gv],
                })
            }
        };
        let colours = match self.corner_colours {
            None => None,
            Some(c) => {
                let channel = |k: usize| affine(c.map(|rgb| srgb_to_linear(rgb[k])));
                let (r, g, b) = (channel(0)?, channel(1)?, channel(2)?);
                Some(ColourMap {
                    at_anchor: DVec3::new(r.0, g.0, b.0),
                    gradient: [r.1, g.1, b.1],
                })
            }
        };
        Some(Surface {
            anchor: corners[0],
            uv,
            colours,
            unlit: self.unlit,
        })
    }
}

/// Most triangles one mesh may have (about 15 GB of memory at 300 bytes each): a lying or
/// enormous header fails at once instead of exhausting memory.
pub(crate) const MAX_MESH_TRIANGLES: usize = 50_000_000;

/// A mesh's triangles in parts (a glTF's placed primitives; one part for PLY and OBJ), in
/// order: they are made into faces in chunks that span parts, each part freed once all of it is
/// made, so a mesh's triangles are never copied into one list (144 bytes a triangle;
/// docs/benchmarks.md, "evening2 (load)" and "night2 (parts)").
pub(super) type MeshParts = Vec<Vec<MeshTriangle>>;
/// The textures a mesh file names, found beside it (and inside the scene's folder).
pub(super) struct MeshTextures<'a> {
    pub mesh: &'a Path,
    pub bank: &'a mut TextureBank,
}

impl MeshTextures<'_> {
    /// The bank index of each image of `names` (relative to the mesh file's folder), each
    /// decoded once, the new ones on all threads.
    pub(super) fn images(&mut self, names: &[&str]) -> Result<Vec<u32>, String> {
        let paths = names
            .iter()
            .map(|name| crate::input::inside_folder(self.mesh, name, "texture"))
            .collect::<Result<Vec<PathBuf>, String>>()?;
        let keys: Vec<String> = paths.iter().map(|path| format!("image {}", path.display())).collect();
        self.bank.add_images(&keys, |i| super::texture::open_image(&paths[i]))
    }

    /// [`MeshTextures::images`] of one image.
    pub(super) fn image(&mut self, name: &str) -> Result<u32, String> {
        Ok(self.images(&[name])?[0])
    }
}

/// Texture coordinates as omnisim uses them (v down from the image's top row), from OBJ's and
/// PLY's (v up from the bottom row); non-finite ones are an error naming `what`.
pub(super) fn uv_from_v_up(u: f64, v: f64, what: &dyn Fn() -> String) -> Result<DVec2, String> {
    if u.is_finite() && v.is_finite() {
        Ok(DVec2::new(u, 1.0 - v))
    } else {
        Err(format!("{}: texture coordinate ({u}, {v}) is not finite", what()))
    }
}

/// The rounded mean of a face's corner colours; `None` unless every corner has one.
pub(super) fn mean_colour(colours: impl Iterator<Item = Option<[u8; 3]>>) -> Option<[u8; 3]> {
    let mut sum = [0u32; 3];
    let mut count = 0u32;
    for c in colours {
        let c = c?;
        for k in 0..3 {
            sum[k] += u32::from(c[k]);
        }
        count += 1;
    }
    (count > 0).then(|| sum.map(|s| ((s + count / 2) / count) as u8))
}
