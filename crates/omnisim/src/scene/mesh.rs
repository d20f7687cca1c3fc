//! Reads triangle meshes (PLY through ply-rs-bw here, OBJ through tobj in `obj.rs`, glTF in
//! `gltf/`) so that real-world geometry and other tools' scenes can be placed in a scene: picks
//! the reader by the file's extension; the triangles they fill are in `mesh_data.rs`.

use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::{DVec2, DVec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Encoding, Property, PropertyAccess, PropertyAccessResult};

use super::mesh_data::{
    CornerUvs, MAX_MESH_TRIANGLES, MeshParts, MeshTextures, MeshTriangle, mean_colour, uv_from_v_up,
};
use super::texture::Wrap;
use super::texture_bank::TextureBank;

/// Reads a mesh file. `path` must be a regular file of at most [`crate::input::MESH_LIMIT`]
/// bytes; errors name the file and a position, never the bytes found there.
pub(super) fn load(path: &Path, bank: &mut TextureBank) -> Result<MeshParts, String> {
    let reader = crate::input::open_regular(path, crate::input::MESH_LIMIT).map_err(|e| match e {
        crate::input::InputError::Io { error, .. } if error.kind() == std::io::ErrorKind::NotFound => format!(
            "{}: file not found; mesh paths are relative to the scene file's folder",
            path.display()
        ),
        other => other.to_string(),
    })?;
    let mut reader = BufReader::new(reader);
    let textures = &mut MeshTextures { mesh: path, bank };
    let result = match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("ply") => load_ply(reader, textures).map(|triangles| vec![triangles]),
        Some("obj") => super::obj::load_obj(reader, textures).map(|triangles| vec![triangles]),
        Some("gltf" | "glb") => {
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut reader, &mut bytes).map_err(|e| format!("{}: {e}", path.display()))?;
            super::gltf::load_gltf(&bytes, textures)
        }
        _ => Err("unknown mesh format; use a .ply, .obj, .gltf or .glb file".into()),
    };
    let parts = result.map_err(|e| format!("{}: {e}", path.display()))?;
    if parts.iter().all(Vec::is_empty) {
        return Err(format!("{}: the mesh has no triangles", path.display()));
    }
    Ok(parts)
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => f64::from(v),
        Property::UChar(v) => f64::from(v),
        Property::Short(v) => f64::from(v),
        Property::UShort(v) => f64::from(v),
        Property::Int(v) => f64::from(v),
        Property::UInt(v) => f64::from(v),
        Property::Float(v) => f64::from(v),
        Property::Double(v) => v,
        _ => return None,
    })
}

fn float_list(p: Property) -> Option<Vec<f64>> {
    Some(match p {
        Property::ListFloat(v) => v.into_iter().map(f64::from).collect(),
        Property::ListDouble(v) => v,
        _ => return None,
    })
}

fn index_list(p: Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
        Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
        Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
        Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
        _ => return None,
    })
}

/// A colour channel's byte: integer properties as they are (clamped to 0–255), float ones
/// (as some scanners' writers give `float red` …) from [0, 1].
fn colour_byte(p: &Property) -> Option<u8> {
    let v = scalar(p)?;
    let v = if matches!(p, Property::Float(_) | Property::Double(_)) {
        (v * 255.0).round()
    } else {
        v
    };
    Some(v.clamp(0.0, 255.0) as u8)
}

/// The colour channel a PLY property name stands for.
fn channel(name: &str) -> Option<usize> {
    match name {
        "red" | "r" => Some(0),
        "green" | "g" => Some(1),
        "blue" | "b" => Some(2),
        _ => None,
    }
}

/// A PLY vertex as omnisim needs it: ply-rs's default element (a hash map per vertex) takes
/// ten times the memory.
#[derive(Default)]
struct PlyVertex {
    position: [f64; 3],
    /// Which of x, y, z were given.
    given: [bool; 3],
    rgb: [Option<u8>; 3],
    /// Texture coordinates (u, v up), where given.
    uv: [Option<f64>; 2],
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let axis = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "u" | "s" | "texture_u" | "texture_s" => {
                self.uv[0] = scalar(&property);
                return PropertyAccessResult::Ignored;
            }
            "v" | "t" | "texture_v" | "texture_t" => {
                self.uv[1] = scalar(&property);
                return PropertyAccessResult::Ignored;
            }
            _ => {
                if let (Some(k), Some(v)) = (channel(name), colour_byte(&property)) {
                    self.rgb[k] = Some(v);
                }
                return PropertyAccessResult::Ignored;
            }
        };
        match scalar(&property) {
            Some(v) => {
                (self.position[axis], self.given[axis]) = (v, true);
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

#[derive(Default)]
struct PlyFace {
    indices: Vec<i64>,
    rgb: [Option<u8>; 3],
    /// Per-corner texture coordinates u0 v0 u1 v1 … (as `ScanNet` and `Matterport` write them).
    texcoord: Vec<f64>,
    /// Which `comment TextureFile` the texture coordinates refer to (Matterport).
    texnumber: Option<f64>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if let Some(k) = channel(name) {
            self.rgb[k] = colour_byte(&property);
            return PropertyAccessResult::Ignored;
        }
        if name == "texcoord" {
            self.texcoord = float_list(property).unwrap_or_default();
            return PropertyAccessResult::Ignored;
        }
        if name == "texnumber" {
            self.texnumber = scalar(&property);
            return PropertyAccessResult::Ignored;
        }
        if !matches!(name, "vertex_indices" | "vertex_index") {
            return PropertyAccessResult::Ignored;
        }
        match index_list(property) {
            Some(indices) => {
                self.indices = indices;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// Elements other than vertices and faces are read past.
struct Skipped;

impl PropertyAccess for Skipped {
    fn new() -> Self {
        Skipped
    }
}

fn rgb(channels: [Option<u8>; 3]) -> Option<[u8; 3]> {
    Some([channels[0]?, channels[1]?, channels[2]?])
}

/// Where a PLY parse failed and what was expected, without the parser's message (which quotes
/// the line it could not read: a mesh path pointing at a secret file must not print it).
fn ply_error(stage: &str, error: &ply_rs_bw::parser::ParseError, ascii: bool) -> String {
    let at = match error.line() {
        Some(line) if ascii || stage == "header" => format!("line {line}: "),
        _ => String::new(),
    };
    let what = match error.kind() {
        std::io::ErrorKind::UnexpectedEof => format!("the file ends inside the {stage}"),
        _ if stage == "header" => "expected a PLY header: 'ply', 'format ascii|binary_little_endian|binary_big_endian \
             1.0', then 'comment', 'element' and 'property' lines, then 'end_header'"
            .to_string(),
        _ => format!("the {stage} does not match what the header declares"),
    };
    format!("not a readable PLY file: {at}{what}")
}

fn load_ply(reader: impl BufRead, textures: &mut MeshTextures) -> Result<Vec<MeshTriangle>, String> {
    let mut reader = Reader::new(reader);
    let vertex_parser = Parser::<PlyVertex>::new();
    let header = vertex_parser
        .read_header(&mut reader)
        .map_err(|e| ply_error("header", &e, true))?;
    let ascii = header.encoding == Encoding::Ascii;
    let (mut vertices, mut faces) = (None, None);
    for (name, element) in &header.elements {
        let stage = format!("data of element '{name}'");
        let error = |e| ply_error(&stage, &e, ascii);
        match name.as_str() {
            "vertex" => {
                vertices = Some(
                    vertex_parser
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(error)?,
                );
            }
            "face" => {
                if element.count > MAX_MESH_TRIANGLES {
                    return Err(format!(
                        "{} faces; omnisim reads at most {MAX_MESH_TRIANGLES} per mesh",
                        element.count
                    ));
                }
                faces = Some(
                    Parser::<PlyFace>::new()
                        .read_payload_for_element(&mut reader, element, &header)
                        .map_err(error)?,
                );
            }
            _ => {
                Parser::<Skipped>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(error)?;
            }
        }
        if vertices.is_some() && faces.is_some() {
            break;
        }
    }
    let vertices = vertices.ok_or("the PLY file has no 'vertex' element")?;
    let faces = faces.ok_or("the PLY file has no 'face' element (a point cloud is not a mesh)")?;
    if let Some(i) = vertices.iter().position(|v| v.given != [true; 3]) {
        return Err(format!("vertex {i} lacks a numeric x, y or z"));
    }
    // `comment TextureFile name.png` lines (ScanNet, Matterport), decoded when a face uses one.
    let texture_files: Vec<&str> = header
        .comments
        .iter()
        .filter_map(|c| c.trim().strip_prefix("TextureFile"))
        .map(str::trim)
        .collect();
    let mut texture_ids: Vec<Option<u32>> = vec![None; texture_files.len()];
    let mut triangles = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let corner = |i: i64| {
            usize::try_from(i).ok().and_then(|i| vertices.get(i)).ok_or_else(|| {
                format!(
                    "face {f} refers to vertex {i}, but there are {} vertices",
                    vertices.len()
                )
            })
        };
        let corners = face.indices.iter().map(|&i| corner(i)).collect::<Result<Vec<_>, _>>()?;
        if corners.len() < 3 {
            return Err(format!(
                "face {f} has {} vertices; a face needs 3 or more",
                corners.len()
            ));
        }
        let face_colour = rgb(face.rgb).or_else(|| mean_colour(corners.iter().map(|c| rgb(c.rgb))));
        // Vertex colours, interpolated, where the face has no colour of its own.
        let vertex_colours: Option<Vec<[u8; 3]>> = match face.rgb {
            [None, None, None] => corners.iter().map(|c| rgb(c.rgb)).collect(),
            _ => None,
        };
        let uvs = ply_face_uvs(f, face, &corners)?;
        let texture = match (&uvs, texture_files.is_empty()) {
            (Some(_), false) => {
                let number = face.texnumber.unwrap_or(0.0);
                let slot = Some(number)
                    .filter(|n| n.fract() == 0.0 && *n >= 0.0 && (*n as usize) < texture_files.len())
                    .ok_or_else(|| {
                        format!(
                            "face {f} has texnumber {number}, but the header names {} TextureFile(s)",
                            texture_files.len()
                        )
                    })? as usize;
                if texture_ids[slot].is_none() {
                    texture_ids[slot] = Some(textures.image(texture_files[slot])?);
                }
                texture_ids[slot]
            }
            _ => None,
        };
        let point = |v: &PlyVertex| DVec3::from_array(v.position);
        for k in 1..corners.len() - 1 {
            if triangles.len() == MAX_MESH_TRIANGLES {
                return Err(format!(
                    "more than {MAX_MESH_TRIANGLES} triangles; omnisim reads at most that many per mesh"
                ));
            }
            let fan = [0, k, k + 1];
            triangles.push(MeshTriangle {
                vertices: fan.map(|c| point(corners[c])),
                colour: face_colour,
                texture: texture.zip(uvs.as_ref()).map(|(texture, uvs)| CornerUvs {
                    texture,
                    wrap: [Wrap::Repeat; 2],
                    uv: fan.map(|c| uvs[c]),
                }),
                corner_colours: vertex_colours.as_ref().map(|c| fan.map(|k| c[k])),
                unlit: false,
            });
        }
    }
    Ok(triangles)
}

/// The texture coordinates of a PLY face's corners: its own `texcoord` list, else its
/// vertices' u, v; `None` without either.
fn ply_face_uvs(f: usize, face: &PlyFace, corners: &[&PlyVertex]) -> Result<Option<Vec<DVec2>>, String> {
    let what = || format!("face {f}");
    if !face.texcoord.is_empty() {
        if face.texcoord.len() != 2 * corners.len() {
            return Err(format!(
                "face {f} has {} texcoord values for {} corners; give two (u, v) per corner",
                face.texcoord.len(),
                corners.len()
            ));
        }
        return face
            .texcoord
            .chunks_exact(2)
            .map(|uv| uv_from_v_up(uv[0], uv[1], &what))
            .collect::<Result<Vec<_>, _>>()
            .map(Some);
    }
    let given: Option<Vec<(f64, f64)>> = corners.iter().map(|c| Some((c.uv[0]?, c.uv[1]?))).collect();
    given
        .map(|uvs| uvs.into_iter().map(|(u, v)| uv_from_v_up(u, v, &what)).collect())
        .transpose()
}
