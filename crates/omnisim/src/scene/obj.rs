//! Wavefront OBJ meshes through tobj, with their MTL materials: `Kd` (the face colour, a
//! linear reflectance) and `map_Kd` (a texture read through the `vt` coordinates, tinted by
//! `Kd` as the MTL format says). The `mtllib` is opened under the rules of meshes: relative to
//! the OBJ's folder and inside it, a regular file of bounded size.

use std::cell::RefCell;
use std::io::BufRead;
use std::path::Path;

use glam::dvec3;

use super::lighting::linear_to_srgb;
use super::mesh::{CornerUvs, MeshTextures, MeshTriangle, mean_colour, uv_from_v_up};
use super::texture::Wrap;

/// Largest MTL file read.
const MTL_LIMIT: u64 = 16 << 20;

/// One material as the triangles use it: sRGB face colour and texture, if any.
struct Material {
    colour: Option<[u8; 3]>,
    texture: Option<u32>,
}

/// Reads an OBJ's triangles, their vertex colours, and through its MTL their colours and
/// textures.
pub(super) fn load_obj(mut reader: impl BufRead, textures: &mut MeshTextures) -> Result<Vec<MeshTriangle>, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // tobj's material loader can only say that it failed: the reason waits here.
    let mtl_problem: RefCell<Option<String>> = RefCell::new(None);
    let load_mtl = |name: &Path| {
        let opened = name
            .to_str()
            .ok_or_else(|| "the mtllib name is not UTF-8".to_string())
            .and_then(|name| super::library::inside_folder(textures.mesh, name, "mtllib"))
            .and_then(|path| crate::input::open_regular(&path, MTL_LIMIT).map_err(|e| format!("mtllib: {e}")));
        match opened {
            Ok(file) => tobj::load_mtl_buf(&mut std::io::BufReader::new(file)).inspect_err(|_| {
                *mtl_problem.borrow_mut() = Some("mtllib: not a readable MTL file".into());
            }),
            Err(problem) => {
                *mtl_problem.borrow_mut() = Some(problem);
                Err(tobj::LoadError::OpenFileFailed)
            }
        }
    };
    let (models, materials) =
        tobj::load_obj_buf(&mut reader, &options, load_mtl).map_err(|e| format!("not a readable OBJ file: {e}"))?;
    if let Some(problem) = mtl_problem.into_inner() {
        return Err(problem);
    }
    // An OBJ without an mtllib has no materials; one whose mtllib failed was refused above.
    let materials = materials.unwrap_or_default();
    // Every material's texture at once: they decode on all threads.
    let names: Vec<&str> = materials.iter().filter_map(|m| m.diffuse_texture.as_deref()).collect();
    let mut images = textures.images(&names)?.into_iter();
    let materials: Vec<Material> = materials
        .iter()
        .map(|m| Material {
            colour: m.diffuse.map(|kd| kd.map(|k| linear_to_srgb(f64::from(k)))),
            texture: m.diffuse_texture.as_ref().and_then(|_| images.next()),
        })
        .collect();
    let mut triangles = Vec::new();
    for model in models {
        let mesh = &model.mesh;
        let missing = |what: &str| format!("object '{}' refers to a {what} that does not exist", model.name);
        let position = |i: u32| {
            let i = i as usize * 3;
            mesh.positions
                .get(i..i + 3)
                .map(|p| dvec3(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
                .ok_or_else(|| missing("vertex"))
        };
        let colour = |i: u32| {
            let i = i as usize * 3;
            mesh.vertex_color
                .get(i..i + 3)
                .map(|c| [c[0], c[1], c[2]].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
        };
        let material = match mesh.material_id {
            Some(id) => Some(materials.get(id).ok_or_else(|| missing("material"))?),
            None => None,
        };
        let texture = material.and_then(|m| m.texture).filter(|_| !mesh.texcoords.is_empty());
        for (t, corners) in mesh.indices.chunks_exact(3).enumerate() {
            let corner_colours: Option<Vec<[u8; 3]>> = corners.iter().map(|&i| colour(i)).collect();
            let uv = |i: u32| {
                let i = i as usize * 2;
                let what = || format!("object '{}' triangle {t}", model.name);
                let uv = mesh
                    .texcoords
                    .get(i..i + 2)
                    .ok_or_else(|| missing("texture coordinate"))?;
                uv_from_v_up(f64::from(uv[0]), f64::from(uv[1]), &what)
            };
            let texture = match texture {
                Some(texture) => Some(CornerUvs {
                    texture,
                    wrap: [Wrap::Repeat; 2],
                    uv: [uv(corners[0])?, uv(corners[1])?, uv(corners[2])?],
                }),
                None => None,
            };
            triangles.push(MeshTriangle {
                vertices: [position(corners[0])?, position(corners[1])?, position(corners[2])?],
                colour: material
                    .and_then(|m| m.colour)
                    .or_else(|| mean_colour(corner_colours.iter().flatten().map(|&c| Some(c)))),
                texture,
                corner_colours: corner_colours.map(|c| [c[0], c[1], c[2]]),
                unlit: false,
            });
        }
    }
    Ok(triangles)
}
