//! Reads triangle meshes (PLY through ply-rs-bw, OBJ through tobj) so that real-world geometry
//! and other tools' scenes can be placed in a scene.

use std::path::Path;

use glam::{DVec3, dvec3};
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};

/// One triangle of a mesh, in the mesh file's own coordinates.
pub(super) struct MeshTriangle {
    pub vertices: [DVec3; 3],
    /// Face colour from the file (face colour, else the mean of vertex colours), if any.
    pub colour: Option<[u8; 3]>,
}

pub(super) fn load(path: &Path) -> Result<Vec<MeshTriangle>, String> {
    if !path.exists() {
        return Err("file not found; the path is relative to the scene file's folder".into());
    }
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("ply") => load_ply(path),
        Some("obj") => load_obj(path),
        _ => Err("unknown mesh format; use a .ply or .obj file".into()),
    }
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

fn index_list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUChar(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUShort(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListInt(v) => v.iter().map(|&i| i as i64).collect(),
        Property::ListUInt(v) => v.iter().map(|&i| i as i64).collect(),
        _ => return None,
    })
}

fn colour_of(element: &DefaultElement) -> Option<[u8; 3]> {
    let channel = |names: [&str; 2]| {
        names
            .iter()
            .find_map(|n| element.get(*n).and_then(scalar))
            .map(|v| v.clamp(0.0, 255.0) as u8)
    };
    Some([
        channel(["red", "r"])?,
        channel(["green", "g"])?,
        channel(["blue", "b"])?,
    ])
}

fn load_ply(path: &Path) -> Result<Vec<MeshTriangle>, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut reader = std::io::BufReader::new(file);
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut reader)
        .map_err(|e| format!("not a readable PLY file: {e}"))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or("the PLY file has no 'vertex' element")?;
    let faces = ply
        .payload
        .get("face")
        .ok_or("the PLY file has no 'face' element (a point cloud is not a mesh)")?;
    let positions = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let c = |k: &str| {
                v.get(k)
                    .and_then(scalar)
                    .ok_or(format!("vertex {i} has no numeric '{k}'"))
            };
            Ok((dvec3(c("x")?, c("y")?, c("z")?), colour_of(v)))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let mut triangles = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let indices = ["vertex_indices", "vertex_index"]
            .iter()
            .find_map(|k| face.get(*k).and_then(index_list))
            .ok_or(format!("face {f} has no 'vertex_indices' list"))?;
        let corner = |i: i64| {
            usize::try_from(i).ok().and_then(|i| positions.get(i)).ok_or(format!(
                "face {f} refers to vertex {i}, but there are {} vertices",
                positions.len()
            ))
        };
        let corners = indices.iter().map(|&i| corner(i)).collect::<Result<Vec<_>, _>>()?;
        if corners.len() < 3 {
            return Err(format!(
                "face {f} has {} vertices; a face needs 3 or more",
                corners.len()
            ));
        }
        let face_colour = colour_of(face).or_else(|| mean_colour(corners.iter().map(|c| c.1)));
        for k in 1..corners.len() - 1 {
            triangles.push(MeshTriangle {
                vertices: [corners[0].0, corners[k].0, corners[k + 1].0],
                colour: face_colour,
            });
        }
    }
    Ok(triangles)
}

fn mean_colour(colours: impl Iterator<Item = Option<[u8; 3]>>) -> Option<[u8; 3]> {
    let mut sum = [0u32; 3];
    let mut count = 0u32;
    for c in colours {
        let c = c?;
        for k in 0..3 {
            sum[k] += c[k] as u32;
        }
        count += 1;
    }
    (count > 0).then(|| sum.map(|s| ((s + count / 2) / count) as u8))
}

fn load_obj(path: &Path) -> Result<Vec<MeshTriangle>, String> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| format!("not a readable OBJ file: {e}"))?;
    let mut triangles = Vec::new();
    for model in models {
        let mesh = &model.mesh;
        let position = |i: u32| {
            let i = i as usize * 3;
            mesh.positions
                .get(i..i + 3)
                .map(|p| dvec3(p[0] as f64, p[1] as f64, p[2] as f64))
                .ok_or_else(|| format!("object '{}' refers to a vertex that does not exist", model.name))
        };
        let colour = |i: u32| {
            let i = i as usize * 3;
            mesh.vertex_color
                .get(i..i + 3)
                .map(|c| [c[0], c[1], c[2]].map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
        };
        for t in mesh.indices.chunks_exact(3) {
            triangles.push(MeshTriangle {
                vertices: [position(t[0])?, position(t[1])?, position(t[2])?],
                colour: mean_colour(t.iter().map(|&i| colour(i))),
            });
        }
    }
    Ok(triangles)
}
